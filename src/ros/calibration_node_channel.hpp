// calibration_node's per-test-instrument state (CalibrationNode::Channel) and small helpers
// shared by the node's source files (calibration_node*.cpp); private to the node, not installed.
#pragma once

#include "magnetometer_insitu_calibration/estimation/calibration_change.hpp"
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"

#include <atomic>
#include <cstddef>
#include <limits>
#include <memory>
#include <mutex>
#include <string>

namespace magnetometer_insitu_calibration {
namespace calibration_node_detail {

constexpr double kNanoteslaPerTesla = 1e9;

inline void add_counters(PairingCounters& total, const PairingCounters& more) {
  total.paired += more.paired;
  total.unpaired_reference += more.unpaired_reference;
  total.unpaired_test += more.unpaired_test;
  total.late += more.late;
  total.duplicates += more.duplicates;
  total.invalid += more.invalid;
}

/// The message's field (tesla, its frame) in nT.
inline Eigen::Vector3d nanotesla(const sensor_msgs::MagneticField& message) {
  return kNanoteslaPerTesla *
         Eigen::Vector3d(message.magnetic_field.x, message.magnetic_field.y, message.magnetic_field.z);
}

}  // namespace calibration_node_detail

/// One test instrument: its subscription, pairing, windows and the worker's results.
struct CalibrationNode::Channel {
  Channel(const TestInstrumentSettings& s, const CalibrationNodeSettings& node)
      : settings(s),
        pairer(node.pairing_tolerance_s, node.pairing_max_wait_s),
        windows(node.window_s, node.step_s, node.estimation_period_s()),
        temperature(node.window_s + 2.0 * node.gap_rule.temperature_max_gap_s) {
    if (node.decimating()) {
      reference_decimator = std::make_unique<StreamingDecimator>(node.input_period_s, node.decimation);
      test_decimator = std::make_unique<StreamingDecimator>(node.input_period_s, node.decimation);
    }
  }

  TestInstrumentSettings settings;
  ros::Subscriber subscriber;
  ros::Publisher publisher;
  StreamMonitor test;
  // Callback thread only:
  StreamPairer pairer;
  PairingCounters counters_before_reset;
  std::unique_ptr<StreamingDecimator> reference_decimator, test_decimator;
  SlidingWindowBuffer windows;
  // Thermometer (settings.temperature_topic): callback thread only.
  ros::Subscriber temperature_subscriber;
  TemperatureBuffer temperature;
  std::size_t temperature_messages = 0;
  double temperature_last_C = std::numeric_limits<double>::quiet_NaN();
  double temperature_last_stamp_s = std::numeric_limits<double>::quiet_NaN();
  bool any_pair = false;
  double last_pair_s = 0.0;
  std::size_t pipeline_resets = 0, decimator_restarts = 0;
  std::size_t reported_late = 0, reported_duplicates = 0, reported_dropped = 0;
  std::atomic<std::size_t> dropped_busy{0};

  // Written by the worker, read by the diagnostics: under results_mutex.
  std::mutex results_mutex;
  std::size_t estimated = 0, accepted = 0, flagged = 0, failed = 0, files_written = 0;
  bool last_failed = false;
  std::string last_failure;
  std::string last_window, last_quality;
  bool last_accepted = false;
  std::string last_accepted_window, last_accepted_stamp;
  std::string file_error;
  double last_duration_s = 0.0;
  double last_delay_s = std::numeric_limits<double>::quiet_NaN(), last_delay_ci95_s = last_delay_s;
  std::string last_method, last_band, last_offset;
  std::string last_eiv;  ///< noise model of the last window's errors-in-variables step
  std::size_t spikes_removed = 0;  ///< values despiked, all windows
  std::string last_weights, last_intervals;  ///< of the last window (WindowEstimate::weights, ::intervals)
  std::string last_reference_noise;      ///< the hat's or the pair's noise of the last window ("" when neither is active)
  std::size_t hat_identified_windows = 0;  ///< windows corrected with the hat's reference noise
  std::size_t pair_identified_windows = 0;  ///< windows corrected with the pair's reference noise
  ResponseSummary last_response;  ///< relative response over the band used (bands == 0: none yet)
  std::string last_temperature;   ///< temperature terms of the last window: fitted or why not
  std::string last_response_model;  ///< response model of the last window: fitted, applied, or why not
  std::size_t response_model_applied_windows = 0;  ///< windows estimated through a modelled filter
  std::string last_temperature_apparent;  ///< a (nT/degC) with 95 % half-widths, "" when not fitted
  std::size_t temperature_fitted_windows = 0;
  // Change check: the accepted calibration the sliding windows are compared with (the first
  // window accepted since start, or the calibration file loaded at start).
  std::unique_ptr<WindowEstimate> baseline;
  std::string baseline_window, baseline_source = "none";
  bool change_checked = false;
  CalibrationChange last_change;
  std::string last_change_window;
  std::size_t changes_detected = 0;
  std::string resume_state = "not tried";
  // TF (~publish_tf).
  std::size_t tf_published = 0;
  std::string tf_state = "off (~publish_tf false)";
  double tf_angle_deg = std::numeric_limits<double>::quiet_NaN();  ///< angle of the published rotation, deg

  PairingCounters counters() const {
    PairingCounters total = counters_before_reset;
    calibration_node_detail::add_counters(total, pairer.counters());
    return total;
  }
};

}  // namespace magnetometer_insitu_calibration
