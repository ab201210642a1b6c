// calibration_node's per-test-instrument state (CalibrationNode::Channel) and small helpers
// shared by the node's source files (calibration_node*.cpp); private to the node, not installed.
#pragma once

#include "magnetometer_insitu_calibration/estimation/calibration_change.hpp"
#include "magnetometer_insitu_calibration/ros/si_units.hpp"
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"

#include <atomic>
#include <cstddef>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace magnetometer_insitu_calibration {
namespace calibration_node_detail {

/// The message's field (tesla, its frame) in nT.
inline Eigen::Vector3d nanotesla(const sensor_msgs::MagneticField& message) {
  return kNanoteslaPerTesla *
         Eigen::Vector3d(message.magnetic_field.x, message.magnetic_field.y, message.magnetic_field.z);
}

}  // namespace calibration_node_detail

/// One test instrument: its ROS ends, and the worker's results for the diagnostics.
struct CalibrationNode::Channel {
  explicit Channel(const TestInstrumentSettings& s) : settings(s) {}

  TestInstrumentSettings settings;
  ros::Subscriber subscriber, temperature_subscriber;
  ros::Publisher publisher;
  // Callback thread only:
  StreamMonitor test;
  std::size_t temperature_messages = 0;
  double temperature_last_C = std::numeric_limits<double>::quiet_NaN();
  double temperature_last_stamp_s = std::numeric_limits<double>::quiet_NaN();
  std::size_t reported_late = 0, reported_duplicates = 0, reported_dropped = 0;
  std::atomic<std::size_t> dropped_busy{0};

  // Written by the worker, read by the diagnostics: under results_mutex.
  std::mutex results_mutex;
  std::size_t estimated = 0, accepted = 0, flagged = 0, failed = 0, files_written = 0;
  /// The last calibrated window, its time span as text and how long it took.
  std::optional<CalibrationWindow> last;
  std::string last_window, last_quality;  ///< its time span; its quality as published ("name: text")
  bool last_accepted = false;
  double last_duration_s = 0.0;
  bool last_failed = false;
  std::string last_failure;
  std::string last_accepted_window, last_accepted_stamp;
  std::string file_error;
  // Counts over all windows.
  std::size_t hat_windows = 0;        ///< corrected with the hat's reference noise
  std::size_t pair_windows = 0;       ///< corrected with the pair's reference noise
  std::size_t model_applied_windows = 0;        ///< estimated through a modelled filter
  std::size_t temperature_fitted_windows = 0;   ///< with temperature terms
  // Change check: the accepted calibration the sliding windows are compared with (the first
  // window accepted since start, or the calibration file loaded at start).
  std::unique_ptr<WindowEstimate> baseline;
  std::string baseline_window, baseline_source = "none";
  bool change_checked = false;
  CalibrationChange last_change;
  std::string last_change_window;
  std::size_t changes_detected = 0;
  std::string resume_state = "not tried";
  bool resume_refused = false;  ///< the resumed file was found not of this stream (WARN until a window is accepted)
  /// The calibration resumed from the file, until the first test sample decides whether it is of
  /// this stream (calibration_stream_mismatch); callback thread.
  std::optional<MagnetometerCalibration> resumed_unchecked;
  // TF (~publish_tf).
  std::size_t tf_published = 0;
  std::string tf_state = "off (~publish_tf false)";
  double tf_angle_deg = std::numeric_limits<double>::quiet_NaN();  ///< angle of the published rotation, deg
};

}  // namespace magnetometer_insitu_calibration
