// calibration_node, the input side: parameters, subscriptions, the two streams' monitors, pairing
// and decimation into each test instrument's sliding windows (see calibration_node.hpp).
// Runs on the ROS callback thread; windows go to the worker by enqueue()
// (calibration_node_windows.cpp).
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"

#include "calibration_node_channel.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/ros/parameters.hpp"

#include <algorithm>

namespace magnetometer_insitu_calibration {

using calibration_node_detail::add_counters;
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
  reference_.topic = settings_.reference_topic;
  if (settings_.publish_tf) tf_broadcaster_ = std::make_unique<tf2_ros::StaticTransformBroadcaster>();
  ros::TransportHints hints = ros::TransportHints().tcpNoDelay();
  updater_.setHardwareID("reference " + nh_.resolveName(settings_.reference_topic));
  updater_.add("reference", [this](DiagnosticStatusWrapper& status) { diagnose_reference(status); });
  if (settings_.hat_active()) coincident_ = std::make_unique<CoincidentWindows>(settings_.tests.size());
  for (std::size_t i = 0; i < settings_.tests.size(); ++i) {
    const TestInstrumentSettings& t = settings_.tests[i];
    channels_.push_back(std::make_unique<Channel>(t, settings_));
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
    ROS_INFO("%s: test '%s' on %s -> %s, file %s, temperature %s", node_name_.c_str(), t.name.c_str(),
             nh_.resolveName(t.topic).c_str(), nh_.resolveName(t.calibration_topic).c_str(), t.calibration_file.c_str(),
             t.temperature_topic.empty() ? "none" : nh_.resolveName(t.temperature_topic).c_str());
  }
  reference_subscriber_ = nh_.subscribe(settings_.reference_topic, static_cast<std::uint32_t>(settings_.queue_size),
                                        &CalibrationNode::on_reference, this, hints);
  ROS_INFO("%s: reference %s; window %g s every %g s at %g s (%s); band %g-%g Hz%s; method %s", node_name_.c_str(),
           nh_.resolveName(settings_.reference_topic).c_str(), settings_.window_s, settings_.step_s,
           settings_.estimation_period_s(),
           settings_.decimating() ? "low-passed and decimated" : "input rate", settings_.estimator.band_low_hz,
           settings_.estimator.band_high_hz, settings_.estimator.robust.auto_band ? " (auto band)" : "",
           estimator_method_name(settings_.estimator.method));
  ROS_INFO("%s: errors in variables: %s", node_name_.c_str(), settings_.hat_state().c_str());
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
    for (auto& ch : channels_) reset_pipeline(*ch);
  }
  const Eigen::Vector3d value = nanotesla(*message);
  for (std::size_t i = 0; i < channels_.size(); ++i) {
    channels_[i]->pairer.push_reference(t, value);
    drain_pairs(i);
  }
}

void CalibrationNode::on_test(std::size_t index, const sensor_msgs::MagneticField::ConstPtr& message) {
  Channel& ch = *channels_[index];
  const double t = message->header.stamp.toSec();
  const auto jump = ch.test.observe(t, ros::Time::now().toSec(), message->header.frame_id,
                                    settings_.time_jump_threshold_s);
  if (jump != StreamMonitor::Jump::kNone) {
    ROS_WARN("%s: test '%s' stamps jumped %s to %s", node_name_.c_str(), ch.settings.name.c_str(),
             jump == StreamMonitor::Jump::kForward ? "forward" : "backward", time_for_message(t).c_str());
  }
  if (jump == StreamMonitor::Jump::kBackward) reset_pipeline(ch);
  ch.pairer.push_test(t, nanotesla(*message));
  drain_pairs(index);
}

void CalibrationNode::on_temperature(std::size_t index, const sensor_msgs::Temperature::ConstPtr& message) {
  Channel& ch = *channels_[index];
  ++ch.temperature_messages;
  ch.temperature_last_C = message->temperature;  // deg C (NaN: the sensor had none)
  ch.temperature_last_stamp_s = message->header.stamp.toSec();
  ch.temperature.push(ch.temperature_last_stamp_s, message->temperature);
}

void CalibrationNode::reset_pipeline(Channel& ch) {
  add_counters(ch.counters_before_reset, ch.pairer.counters());
  ch.pairer.reset();
  if (ch.reference_decimator) {
    ch.reference_decimator->reset();
    ch.test_decimator->reset();
  }
  ch.windows.reset();
  for (std::size_t i = 0; coincident_ && i < channels_.size(); ++i) {
    if (channels_[i].get() == &ch) coincident_->reset(i);
  }
  ch.temperature.reset();
  ch.any_pair = false;
  ++ch.pipeline_resets;
  ROS_WARN("%s: test '%s': stamps went backwards, pairing and window restarted", node_name_.c_str(),
           ch.settings.name.c_str());
}

void CalibrationNode::drain_pairs(std::size_t index) {
  Channel& ch = *channels_[index];
  for (const PairedSample& pair : ch.pairer.take_pairs()) {
    auto feed = [&](double t, const Eigen::Vector3d& r, const Eigen::Vector3d& s) {
      const double margin = settings_.gap_rule.temperature_max_gap_s;
      bool completed = false;
      for (WindowData& w : ch.windows.push(t, r, s)) {
        if (!ch.settings.temperature_topic.empty()) {
          w.temperature = ch.temperature.copy(w.start_s - w.period_s - margin, w.end_s() + w.period_s + margin);
        }
        submit(index, std::move(w));
        completed = true;
      }
      if (completed) ch.temperature.drop_before(ch.windows.next_start_s() - ch.windows.period_s() - margin);
    };
    if (!ch.reference_decimator) {
      feed(pair.time_s, pair.reference_nT, pair.test_nT);
    } else {
      // A jump in the paired stamps would make the decimator emit one (NaN) output per missing
      // epoch; restart it instead (the window sees the epochs as missing either way).
      if (ch.any_pair && pair.time_s - ch.last_pair_s > settings_.time_jump_threshold_s) {
        ch.reference_decimator->reset();
        ch.test_decimator->reset();
        ++ch.decimator_restarts;
      }
      const auto r = ch.reference_decimator->push(pair.time_s, pair.reference_nT);
      const auto s = ch.test_decimator->push(pair.time_s, pair.test_nT);
      // Both decimators see the same stamps, so they complete the same epochs.
      for (std::size_t k = 0; k < std::min(r.size(), s.size()); ++k) feed(r[k].first, r[k].second, s[k].second);
    }
    ch.any_pair = true;
    ch.last_pair_s = pair.time_s;
  }
}

}  // namespace magnetometer_insitu_calibration
