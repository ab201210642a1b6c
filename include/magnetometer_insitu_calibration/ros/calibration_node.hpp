// calibration_node: live in-situ calibration of one or several test magnetometers against one
// reference, over a sliding window: a thin ROS layer over the core.
//
// One window, from message to message (units nT and UNIX seconds inside, tesla on the topics):
//   on_reference / on_test (calibration_node.cpp): the message's field in nT, its stamp watched
//       for jumps (StreamMonitor), then LiveCalibrationStreams (core, pipeline/live_streams.hpp:
//       despiking, pairing, decimation, sliding windows, the thermometer, coincident windows for
//       the three-cornered hat) returns the windows the sample completed;
//   enqueue (calibration_node_windows.cpp): each window to the worker's bounded queue;
//   run_worker -> process (calibration_node_windows.cpp): the per-window stage
//       (WindowCalibrator, pipeline/window_calibration.hpp, as calibrate_records uses it), the
//       change check against the accepted calibration;
//   calibration_message -> publish_calibration (calibration_node_output.cpp): the
//       MagnetometerCalibration of every window on the instrument's calibration topic
//       (latched), accepted=false with the failed quality rule when it is flagged; the latest
//       accepted one first written atomically to the instrument's YAML file.
// Resume: at start, a valid accepted calibration in the instrument's calibration file is
// published (latched) at once and becomes the accepted calibration of the change check.
// Change check: every window is compared (check_calibration_change) with the accepted
// calibration: the first window accepted since start, or the file loaded at start; it is kept
// (not replaced by later windows, so that a slow slide of the window over a change is seen).
// Callbacks never wait for the estimator: at most ~max_pending_windows windows wait; the oldest
// is dropped and counted when the worker falls behind.
//
// TF (~publish_tf, off by default): the rotation part of every accepted n, as a static transform
// reference frame_id -> test frame_id on /tf_static (calibration_node_tf.cpp, docs/frames.md).
//
// Time: windows, pairing, jumps use the message stamps (header.stamp); silence is measured in
// ROS time (wall clock, or /clock with /use_sim_time) between arrivals.
//
// Sources: calibration_node.cpp (subscriptions, streams), calibration_node_windows.cpp (queue,
// worker, change check), calibration_node_output.cpp (message, YAML file, resume),
// calibration_node_tf.cpp, calibration_node_diagnostics.cpp, calibration_node_settings.cpp
// (parameters).
#pragma once

#include "magnetometer_insitu_calibration/common/setting_bindings.hpp"

#include "magnetometer_insitu_calibration/estimation/calibration_change.hpp"
#include "magnetometer_insitu_calibration/pipeline/live_streams.hpp"
#include "magnetometer_insitu_calibration/pipeline/window_calibration.hpp"

#include <magnetometer_insitu_calibration/MagnetometerCalibration.h>
#include <magnetometer_insitu_calibration/ScalarField.h>

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
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace magnetometer_insitu_calibration {

/// One test instrument of calibration_node.
struct TestInstrumentSettings {
  std::string name;               ///< label in messages, diagnostics and logs
  std::string topic;              ///< its sensor_msgs/MagneticField topic
  std::string calibration_topic;  ///< MagnetometerCalibration output (latched)
  std::string calibration_file;   ///< YAML of the latest accepted calibration (atomic writes)
  std::string temperature_topic;  ///< its sensor_msgs/Temperature (deg C); "" = none (no temperature terms)
  double input_period_s = 0.0;    ///< its own nominal sample period, s (a ~tests entry's input_period); 0: ~test_input_period
};

/// Every parameter of calibration_node, read and validated once at start-up
/// (config/calibration.yaml documents them).
struct CalibrationNodeSettings {
  std::string reference_topic;
  std::vector<TestInstrumentSettings> tests;
  /// A remote observatory's sensor_msgs/MagneticField (any frame), the instruments of every
  /// window's remote-reference estimate; "" = none.
  std::string remote_topic;
  /// An absolute scalar magnetometer's ScalarField (F), the check of the reference's scale along
  /// the main field in every window (pipeline/scalar_window.hpp); "" = none.
  std::string scalar_topic;
  /// Periods and decimation (s), pairing, window and step (s), despiking, the thermometer margin.
  LiveStreamSettings streams;
  /// The per-window stage: estimator, reference noise, response model, temperature, gap rule.
  WindowCalibrationSettings window;
  CalibrationChangeSettings change;     ///< change check: false-alarm probability, tolerances
  double silent_timeout_s = 10.0;       ///< ROS time without a message before a topic is "silent", s
  double time_jump_threshold_s = 60.0;  ///< stamp step counted as a time jump, s
  int queue_size = 10000;               ///< subscriber queue length, messages
  int max_pending_windows = 8;          ///< windows waiting for the worker
  double diagnostic_period_s = 1.0;     ///< ROS time between diagnostics, s
  bool publish_tf = false;              ///< rotation part of accepted n on /tf_static (reference -> test frame)
  std::string tf_child_frame_suffix;    ///< appended to the test frame_id for the transform's child frame

  /// Windows go to the worker with another test's window of the same epochs (the three-cornered
  /// hat): two or more tests, ~three_cornered_hat, a correction that uses a noise model and no
  /// maker's figure.
  /// The tests as the live streams take them (name, thermometer, own period).
  std::vector<LiveTestInput> live_tests() const {
    std::vector<LiveTestInput> out;
    for (const TestInstrumentSettings& t : tests) out.push_back({t.name, !t.temperature_topic.empty(), t.input_period_s});
    return out;
  }
  bool hat_active() const {
    return window.three_cornered_hat && tests.size() >= 2 && window.corrects_reference_noise() &&
           !window.reference_noise_figure.any();
  }
  /// One line for the start-up log and the diagnostics: where each window's reference noise
  /// model comes from.
  std::string noise_model_state() const;

  /// Reads every private parameter; throws ParameterError naming the first impossible one.
  static CalibrationNodeSettings load(const ros::NodeHandle& private_nh);  // calibration_node_settings.cpp
  /// The declared parameters bound to these settings (the documents' and the tests' view).
  static const SettingBindings<CalibrationNodeSettings>& bindings();
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
    WindowRecords window;
    std::string reference_frame_id, test_frame_id;
  };

  // Streams (calibration_node.cpp): callback thread.
  void on_reference(const sensor_msgs::MagneticField::ConstPtr& message);
  void on_test(std::size_t channel, const sensor_msgs::MagneticField::ConstPtr& message);
  void on_temperature(std::size_t channel, const sensor_msgs::Temperature::ConstPtr& message);
  void on_remote(const sensor_msgs::MagneticField::ConstPtr& message);
  void on_scalar(const ScalarField::ConstPtr& message);
  // Windows (calibration_node_windows.cpp): enqueue on the callback thread, the rest on the worker.
  void enqueue(std::vector<LiveCalibrationStreams::Completed> windows);
  void run_worker();
  void process(Job& job, WindowCalibrator& calibrator);
  // Output (calibration_node_output.cpp).
  /// The message of a calibrated window (the job's window already moved out).
  MagnetometerCalibration calibration_message(const Job& job, const CalibrationWindow& result) const;
  /// Writes an accepted calibration to the channel's file, then publishes it; returns the file
  /// error ("" when written or not accepted).
  std::string publish_calibration(Channel& channel, const MagnetometerCalibration& message);
  void resume_from_file(Channel& channel);
  /// At the test's first sample: a calibration resumed from the file that is not of this stream
  /// (another test name or frame, or a window ending after the sample) is retracted (its latched
  /// message published again with accepted false and the reason), stops being the change
  /// check's baseline, and the diagnostics say why.
  void drop_resumed_if_not_of_stream(Channel& channel, const sensor_msgs::MagneticField& first);
  // TF (calibration_node_tf.cpp): the rotation part of an accepted n on /tf_static.
  void publish_rotation(Channel& channel, const MagnetometerCalibration& message);
  // Diagnostics (calibration_node_diagnostics.cpp). A test's status is built in parts, each
  // adding its keys and the problems it sees (level, message), merged into the summary in order.
  using Problems = std::vector<std::pair<unsigned char, std::string>>;
  void diagnose_reference(diagnostic_updater::DiagnosticStatusWrapper& status);
  void diagnose_channel(std::size_t channel, diagnostic_updater::DiagnosticStatusWrapper& status);
  /// The last window's parameters against the tolerances: OK within, WARN undecided, ERROR outside.
  void diagnose_tolerances(std::size_t channel, diagnostic_updater::DiagnosticStatusWrapper& status);
  /// The live stream: pairing, despiking, decimation, thermometer, windows queued and pending.
  void diagnose_stream(std::size_t channel, diagnostic_updater::DiagnosticStatusWrapper& status, Problems& problems);
  /// The worker's results (under the channel's results_mutex): windows, last estimate, resume,
  /// change check, TF, file.
  void diagnose_results(Channel& channel, diagnostic_updater::DiagnosticStatusWrapper& status, Problems& problems);
  /// "" or, when a stream's measured period is not its parameter's, the problem naming both
  /// (ROS_ERROR once per stream).
  std::string period_mismatch(const StreamMonitor& monitor, double nominal_s, const std::string& stream,
                              const std::string& parameter);
  /// "" or, for a stream paired with the reference by stamp, the problem when its stamps fall
  /// further from the reference's than ~pairing_tolerance in each period (nothing pairs; ROS_ERROR
  /// once per stream).
  std::string phase_mismatch(const StreamMonitor& monitor, EpochAlignment alignment, const std::string& stream);

  ros::NodeHandle nh_, private_nh_;
  CalibrationNodeSettings settings_;
  std::string node_name_;
  StreamMonitor reference_, remote_, scalar_;
  ros::Subscriber reference_subscriber_, remote_subscriber_, scalar_subscriber_;
  std::vector<std::unique_ptr<Channel>> channels_;
  std::unique_ptr<LiveCalibrationStreams> streams_;  ///< callback thread
  diagnostic_updater::Updater updater_;
  ros::Timer diagnostic_timer_;
  /// Made only with ~publish_tf (it advertises /tf_static); used by the constructor (resume),
  /// then by the worker thread only.
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> tf_broadcaster_;
  double started_s_ = 0.0;  ///< ROS time of the first non-zero clock, s
  std::set<std::string> problems_logged_;  ///< streams' period or phase problems logged (diagnostics)

  std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  std::deque<Job> queue_;
  bool stopping_ = false;
  std::thread worker_;
};

}  // namespace magnetometer_insitu_calibration
