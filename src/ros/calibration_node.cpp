// calibration_node, the input side: parameters, subscriptions, the streams' monitors, and the
// messages into the core's live streams (see calibration_node.hpp). Runs on the ROS callback
// thread; completed windows go to the worker by enqueue() (calibration_node_windows.cpp).
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"

#include "calibration_node_channel.hpp"
#include "magnetometer_insitu_calibration/common/atomic_file.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/ros/parameters.hpp"

#include <algorithm>

namespace magnetometer_insitu_calibration {

using calibration_node_detail::nanotesla;
using diagnostic_updater::DiagnosticStatusWrapper;

CalibrationNode::CalibrationNode(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : nh_(nh),
      private_nh_(private_nh),
      settings_(CalibrationNodeSettings::load(private_nh)),
      node_name_(private_nh.getNamespace()),  // the node's name; a nodelet's own name in a manager
      updater_(nh, private_nh, private_nh.getNamespace()) {
  for (const std::string& name : unknown_private_parameters(private_nh_, CalibrationNodeSettings::known_parameters())) {
    ROS_WARN("%s: unknown parameter ~%s is ignored (misspelt?)", node_name_.c_str(), name.c_str());
  }
  // Each calibration file's directory is made (as mkdir -p) and tried now, not at the first
  // accepted window a day later: a file that cannot be written is an impossible parameter.
  for (std::size_t i = 0; i < settings_.tests.size(); ++i) {
    try {
      prepare_file_directory(settings_.tests[i].calibration_file);
    } catch (const std::runtime_error& error) {
      throw ParameterError(private_nh_.hasParam("tests") ? "tests[" + std::to_string(i) + "].calibration_file"
                                                         : std::string("calibration_file"),
                           error.what());
    }
  }
  reference_.topic = settings_.reference_topic;
  if (settings_.publish_tf) tf_broadcaster_ = std::make_unique<tf2_ros::StaticTransformBroadcaster>();
  ros::TransportHints hints = ros::TransportHints().tcpNoDelay();
  updater_.setHardwareID("reference " + nh_.resolveName(settings_.reference_topic));
  updater_.add("reference", [this](DiagnosticStatusWrapper& status) { diagnose_reference(status); });
  streams_ = std::make_unique<LiveCalibrationStreams>(settings_.streams, settings_.live_tests(), settings_.hat_active());
  if (!settings_.remote_topic.empty()) {
    remote_.topic = settings_.remote_topic;
    streams_->add_remote(nh_.resolveName(settings_.remote_topic));
    remote_subscriber_ = nh_.subscribe(settings_.remote_topic, static_cast<std::uint32_t>(settings_.queue_size),
                                       &CalibrationNode::on_remote, this, hints);
  }
  if (!settings_.scalar_topic.empty()) {
    scalar_.topic = settings_.scalar_topic;
    streams_->add_scalar(nh_.resolveName(settings_.scalar_topic));
    scalar_subscriber_ = nh_.subscribe(settings_.scalar_topic, static_cast<std::uint32_t>(settings_.queue_size),
                                       &CalibrationNode::on_scalar, this, hints);
  }
  for (std::size_t i = 0; i < settings_.tests.size(); ++i) {
    const TestInstrumentSettings& t = settings_.tests[i];
    channels_.push_back(std::make_unique<Channel>(t));
    Channel& ch = *channels_.back();
    if (settings_.publish_tf) ch.tf_state = "on, nothing accepted yet";
    ch.test.topic = t.topic;
    ch.publisher = nh_.advertise<MagnetometerCalibration>(t.calibration_topic, 10, /*latch=*/true);
    ch.subscriber = nh_.subscribe<sensor_msgs::MagneticField>(
        t.topic, static_cast<std::uint32_t>(settings_.queue_size),
        boost::function<void(const sensor_msgs::MagneticField::ConstPtr&)>(
            [this, i](const sensor_msgs::MagneticField::ConstPtr& m) { on_test(i, m); }),
        ros::VoidConstPtr(), hints);
    if (!t.temperature_topic.empty()) {
      ch.temperature_subscriber = nh_.subscribe<sensor_msgs::Temperature>(
          t.temperature_topic, static_cast<std::uint32_t>(settings_.queue_size),
          boost::function<void(const sensor_msgs::Temperature::ConstPtr&)>(
              [this, i](const sensor_msgs::Temperature::ConstPtr& m) { on_temperature(i, m); }),
          ros::VoidConstPtr(), hints);
    }
    resume_from_file(ch);
    updater_.add(t.name, [this, i](DiagnosticStatusWrapper& status) { diagnose_channel(i, status); });
    updater_.add(t.name + " tolerances", [this, i](DiagnosticStatusWrapper& status) { diagnose_tolerances(i, status); });
    ROS_INFO("%s: test '%s' on %s -> %s, file %s, temperature %s", node_name_.c_str(), t.name.c_str(),
             nh_.resolveName(t.topic).c_str(), nh_.resolveName(t.calibration_topic).c_str(), t.calibration_file.c_str(),
             t.temperature_topic.empty() ? "none" : nh_.resolveName(t.temperature_topic).c_str());
  }
  reference_subscriber_ = nh_.subscribe(settings_.reference_topic, static_cast<std::uint32_t>(settings_.queue_size),
                                        &CalibrationNode::on_reference, this, hints);
  const LiveStreamSettings& streams = settings_.streams;
  const EstimatorSettings& estimator = settings_.window.estimator;
  ROS_INFO("%s: reference %s; window %g s every %g s at %g s (%s%s); band %g-%g Hz%s; method %s", node_name_.c_str(),
           nh_.resolveName(settings_.reference_topic).c_str(), streams.window_s, streams.step_s,
           streams.estimation_period_s(), epoch_alignment_name(streams.test_plan().alignment),
           streams.despike ? ", despiked" : "", estimator.band_low_hz, estimator.band_high_hz,
           estimator.robust.auto_band ? " (auto band)" : "", estimator_method_name(estimator.method));
  ROS_INFO("%s: errors in variables: %s; remote reference: %s%s; scalar: %s", node_name_.c_str(),
           settings_.noise_model_state().c_str(),
           settings_.remote_topic.empty() ? "none" : nh_.resolveName(settings_.remote_topic).c_str(),
           settings_.remote_topic.empty() ? "" : (std::string(" (") + epoch_alignment_name(streams.remote_side().alignment()) + ")").c_str(),
           settings_.scalar_topic.empty() ? "none" : nh_.resolveName(settings_.scalar_topic).c_str());
  diagnostic_timer_ = nh_.createTimer(ros::Duration(settings_.diagnostic_period_s),
                                      [this](const ros::TimerEvent&) { updater_.force_update(); });
  worker_ = std::thread([this] { run_worker(); });
}

CalibrationNode::~CalibrationNode() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stopping_ = true;
  }
  queue_cv_.notify_all();
  if (worker_.joinable()) worker_.join();
}

void CalibrationNode::on_reference(const sensor_msgs::MagneticField::ConstPtr& message) {
  const double t = message->header.stamp.toSec();
  const auto jump = reference_.observe(t, ros::Time::now().toSec(), message->header.frame_id,
                                       settings_.time_jump_threshold_s);
  if (jump != StreamMonitor::Jump::kNone) {
    ROS_WARN("%s: reference stamps jumped %s to %s", node_name_.c_str(),
             jump == StreamMonitor::Jump::kForward ? "forward" : "backward", time_for_message(t).c_str());
  }
  if (jump == StreamMonitor::Jump::kBackward) {
    streams_->restart_all();
    ROS_WARN("%s: reference stamps went backwards: pairing and windows of every test restarted", node_name_.c_str());
  }
  enqueue(streams_->push_reference(t, nanotesla(*message)));
}

void CalibrationNode::on_test(std::size_t index, const sensor_msgs::MagneticField::ConstPtr& message) {
  Channel& ch = *channels_[index];
  drop_resumed_if_not_of_stream(ch, *message);
  const double t = message->header.stamp.toSec();
  const auto jump = ch.test.observe(t, ros::Time::now().toSec(), message->header.frame_id,
                                    settings_.time_jump_threshold_s);
  if (jump != StreamMonitor::Jump::kNone) {
    ROS_WARN("%s: test '%s' stamps jumped %s to %s", node_name_.c_str(), ch.settings.name.c_str(),
             jump == StreamMonitor::Jump::kForward ? "forward" : "backward", time_for_message(t).c_str());
  }
  if (jump == StreamMonitor::Jump::kBackward) {
    streams_->restart(index);
    ROS_WARN("%s: test '%s': stamps went backwards, pairing and windows restarted", node_name_.c_str(),
             ch.settings.name.c_str());
  }
  enqueue(streams_->push_test(index, t, nanotesla(*message)));
}

void CalibrationNode::on_remote(const sensor_msgs::MagneticField::ConstPtr& message) {
  const double t = message->header.stamp.toSec();
  if (remote_.observe(t, ros::Time::now().toSec(), message->header.frame_id, settings_.time_jump_threshold_s) ==
      StreamMonitor::Jump::kBackward) {
    ROS_WARN("%s: remote stamps went backwards to %s", node_name_.c_str(), time_for_message(t).c_str());
  }
  enqueue(streams_->push_remote(t, nanotesla(*message)));  // the windows that waited for it
}

/// F (tesla on the topic) into the streams at its own stamp; a stamp not after the last is refused.
void CalibrationNode::on_scalar(const ScalarField::ConstPtr& message) {
  const double t = message->header.stamp.toSec();
  scalar_.observe(t, ros::Time::now().toSec(), message->header.frame_id, settings_.time_jump_threshold_s);
  streams_->push_scalar(t, kNanoteslaPerTesla * message->field);
}

void CalibrationNode::on_temperature(std::size_t index, const sensor_msgs::Temperature::ConstPtr& message) {
  Channel& ch = *channels_[index];
  ++ch.temperature_messages;
  ch.temperature_last_C = message->temperature;  // deg C (NaN: the sensor had none)
  ch.temperature_last_stamp_s = message->header.stamp.toSec();
  streams_->push_temperature(index, ch.temperature_last_stamp_s, message->temperature);
}

}  // namespace magnetometer_insitu_calibration
