// calibration_node: live in-situ calibration of one or several test magnetometers against one
// reference, over a sliding window (thin ROS layer over the core).
//
// Data flow, per test instrument (units nT and UNIX seconds inside, tesla on the topics):
//   reference + test sensor_msgs/MagneticField (each in its own frame)
//     -> StreamPairer (pairs by header.stamp within ~pairing_tolerance; counts unpaired, late,
//        duplicate samples)
//     -> StreamingDecimator, both instruments on the same epochs (only when ~input_period is
//        shorter than ~output_period, e.g. LEMI-025 10 Hz -> 1 Hz)
//     -> SlidingWindowBuffer: windows [k step, k step + window) in UNIX time; with the instrument's
//        sensor_msgs/Temperature topic, its samples around the window go with it
//        (TemperatureBuffer)
//     -> worker thread (its own WindowEstimator, the offline CLI's: ~method robust | plain, auto
//        band, EIV, delay): regularize_and_fill on the window copy, the estimate, the temperature
//        terms (fitted and removed when the window has a varying temperature; n then at the
//        window's mean temperature), gap flags, the offset at the window end, the change check
//        against the accepted calibration (WARN)
//     -> MagnetometerCalibration on the instrument's calibration topic (latched), every window,
//        accepted=false with the failed quality rule when it is flagged; the latest accepted
//        one also written atomically to the instrument's YAML file.
// Resume: at start, a valid accepted calibration in the instrument's calibration file is
// published (latched) at once and becomes the accepted calibration of the change check.
// Change check: every window is compared (check_calibration_change) with the accepted
// calibration: the first window accepted since start, or the file loaded at start; it is kept
// (not replaced by later windows, so that a slow slide of the window over a change is seen).
// Callbacks never wait for the estimator: windows are queued (at most ~max_pending_windows,
// the oldest is dropped and counted when the worker falls behind).
//
// TF (~publish_tf, off by default): the rotation part of every accepted n, as a static transform
// reference frame_id -> test frame_id on /tf_static (calibration_node_tf.cpp, docs/frames.md).
//
// Time: windows, pairing, jumps use the message stamps (header.stamp); silence is measured in
// ROS time (wall clock, or /clock with /use_sim_time) between arrivals.
//
// Sources: calibration_node.cpp (subscriptions, pairing, decimation), calibration_node_windows.cpp
// (window queue, worker, estimate, change check), calibration_node_output.cpp (message, YAML
// file, resume), calibration_node_tf.cpp, calibration_node_diagnostics.cpp,
// calibration_node_settings.cpp (parameters).
#pragma once

#include "magnetometer_insitu_calibration/estimation/calibration_change.hpp"
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/estimation/robust_estimator.hpp"
#include "magnetometer_insitu_calibration/preprocessing/gaussian_decimation.hpp"
#include "magnetometer_insitu_calibration/ros/live_three_cornered_hat.hpp"
#include "magnetometer_insitu_calibration/ros/live_window.hpp"
#include "magnetometer_insitu_calibration/preprocessing/stream_pairing.hpp"

#include <magnetometer_insitu_calibration/MagnetometerCalibration.h>

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>
#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/Temperature.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace magnetometer_insitu_calibration {

/// One test instrument of calibration_node.
struct TestInstrumentSettings {
  std::string name;               ///< label in messages, diagnostics and logs
  std::string topic;              ///< its sensor_msgs/MagneticField topic
  std::string calibration_topic;  ///< MagnetometerCalibration output (latched)
  std::string calibration_file;   ///< YAML of the latest accepted calibration (atomic writes)
  std::string temperature_topic;  ///< its sensor_msgs/Temperature (deg C); "" = none (no temperature terms)
};

/// Every parameter of calibration_node, read and validated once at start-up
/// (config/calibration.yaml documents them).
struct CalibrationNodeSettings {
  std::string reference_topic;
  std::vector<TestInstrumentSettings> tests;
  double input_period_s = 1.0;          ///< nominal sample period of both inputs, s
  DecimationSettings decimation;        ///< output_period_s (s), sigma_s (s, 0 = default), half_width_sigmas
  double pairing_tolerance_s = 0.010;   ///< largest |t_test - t_ref| of a pair, s
  double pairing_max_wait_s = 600.0;    ///< longest wait (stamp time) for a partner, s
  double window_s = 86400.0;            ///< window length, s
  double step_s = 3600.0;               ///< step between window starts, s
  WindowGapRule gap_rule;               ///< max_fill_s (s), max_filled_fraction, temperature min range (degC) and max gap (s)
  EstimatorSettings estimator;          ///< band (Hz), gamma, trend, quality rules, method, robust options
  CalibrationChangeSettings change;     ///< change check: false-alarm probability, tolerances
  double silent_timeout_s = 10.0;       ///< ROS time without a message before a topic is "silent", s
  double time_jump_threshold_s = 60.0;  ///< stamp step counted as a time jump, s
  int queue_size = 10000;               ///< subscriber queue length, messages
  int max_pending_windows = 8;          ///< windows waiting for the worker
  double diagnostic_period_s = 1.0;     ///< ROS time between diagnostics, s
  bool publish_tf = false;              ///< rotation part of accepted n on /tf_static (reference -> test frame)
  /// Reference noise from the three-cornered hat of the reference and two tests, per window
  /// (issue 13); in effect only where hat_active().
  bool three_cornered_hat = true;
  /// Reference noise identified from each window's pair above the band (issue 13, session 9;
  /// pipeline/reference_noise.hpp); in effect only where pair_noise_active().
  bool pair_noise = true;
  std::string tf_child_frame_suffix;    ///< appended to the test frame_id for the transform's child frame

  /// True when the inputs are low-passed and decimated to decimation.output_period_s.
  bool decimating() const { return input_period_s < 0.99 * decimation.output_period_s; }
  /// Sample period of the windows, s.
  double estimation_period_s() const { return decimating() ? decimation.output_period_s : input_period_s; }
  /// The hat is used: ~three_cornered_hat, two or more tests, the robust method with eiv given
  /// and no ~reference_noise_pT (a maker's figure, when given, is used instead).
  bool hat_active() const {
    return three_cornered_hat && tests.size() >= 2 && estimator.awaits_identified_noise();
  }
  /// The pair's noise is used where the hat is not: ~pair_noise, the robust method with eiv
  /// given and no ~reference_noise_pT.
  bool pair_noise_active() const {
    return pair_noise && !hat_active() && estimator.awaits_identified_noise();
  }
  /// Why the hat is or is not used, for the diagnostics.
  std::string hat_state() const;

  /// Reads every private parameter; throws ParameterError naming the first impossible one.
  static CalibrationNodeSettings load(const ros::NodeHandle& private_nh);  // calibration_node_settings.cpp
  /// Every private parameter load() reads (others draw a start-up warning).
  static const std::vector<std::string>& known_parameters();
};

class CalibrationNode {
 public:
  /// Reads the parameters (throws ParameterError), subscribes, advertises, starts the worker.
  CalibrationNode(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~CalibrationNode();
  CalibrationNode(const CalibrationNode&) = delete;
  CalibrationNode& operator=(const CalibrationNode&) = delete;

  const CalibrationNodeSettings& settings() const { return settings_; }

 private:
  struct Channel;
  struct Job {
    std::size_t channel = 0;
    WindowData window;
    std::string reference_frame_id, test_frame_id;
    /// With the hat (CoincidentWindows): another test's window of the same epochs, or null.
    std::shared_ptr<const PairedRecord> mate;
    std::size_t mate_channel = 0;
  };

  // Streams (calibration_node.cpp): callback thread.
  void on_reference(const sensor_msgs::MagneticField::ConstPtr& message);
  void on_test(std::size_t channel, const sensor_msgs::MagneticField::ConstPtr& message);
  void on_temperature(std::size_t channel, const sensor_msgs::Temperature::ConstPtr& message);
  void drain_pairs(std::size_t channel);
  void reset_pipeline(Channel& channel);
  // Windows (calibration_node_windows.cpp): enqueue on the callback thread, the rest on the worker.
  /// A completed window: to the queue, or first to coincident_ when the hat is active.
  void submit(std::size_t channel, WindowData&& window);
  void enqueue(std::size_t channel, WindowData&& window, std::shared_ptr<const PairedRecord> mate = nullptr,
               std::size_t mate_channel = 0);
  void run_worker();
  void process(Job& job, WindowEstimator& estimator);
  // Output (calibration_node_output.cpp).
  /// The message of a window estimate (job's window already moved out; period in s).
  MagnetometerCalibration calibration_message(const Job& job, const WindowResult& result, double period) const;
  /// Writes an accepted calibration to the channel's file, then publishes it; returns the file
  /// error ("" when written or not accepted).
  std::string publish_calibration(Channel& channel, const MagnetometerCalibration& message);
  void resume_from_file(Channel& channel);
  // TF (calibration_node_tf.cpp): the rotation part of an accepted n on /tf_static.
  void publish_rotation(Channel& channel, const MagnetometerCalibration& message);
  // Diagnostics (calibration_node_diagnostics.cpp).
  void diagnose_reference(diagnostic_updater::DiagnosticStatusWrapper& status);
  void diagnose_channel(std::size_t channel, diagnostic_updater::DiagnosticStatusWrapper& status);

  ros::NodeHandle nh_, private_nh_;
  CalibrationNodeSettings settings_;
  std::string node_name_;
  StreamMonitor reference_;
  ros::Subscriber reference_subscriber_;
  std::vector<std::unique_ptr<Channel>> channels_;
  std::unique_ptr<CoincidentWindows> coincident_;  ///< hat_active() only; callback thread
  diagnostic_updater::Updater updater_;
  ros::Timer diagnostic_timer_;
  /// Made only with ~publish_tf (it advertises /tf_static); used by the constructor (resume),
  /// then by the worker thread only.
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> tf_broadcaster_;
  double started_s_ = 0.0;  ///< ROS time of the first non-zero clock, s

  std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  std::deque<Job> queue_;
  bool stopping_ = false;
  std::thread worker_;
};

}  // namespace magnetometer_insitu_calibration
