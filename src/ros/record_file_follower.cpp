// record_file_follower: a remote observatory's record files as a MagneticField stream (see
// record_file_follower.hpp). This file: the parameters, construction, the worker (looks,
// publishing, the state file) and shutdown; the diagnostics: record_file_follower_diagnostics.cpp.
#include "magnetometer_insitu_calibration/ros/record_file_follower.hpp"

#include "magnetometer_insitu_calibration/common/atomic_file.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/formats/record_follower_settings.hpp"
#include "magnetometer_insitu_calibration/ros/parameters.hpp"
#include "magnetometer_insitu_calibration/ros/si_units.hpp"

#include <sensor_msgs/MagneticField.h>

#include <cmath>
#include <stdexcept>

namespace magnetometer_insitu_calibration {

namespace {

using F = RecordFileFollowerSettings;

/// Wall seconds between state file writes while a look's samples are published.
constexpr double kStateWritePeriod_s = 10.0;
/// Warnings of one look logged at most; the rest counted in one line.
constexpr std::size_t kWarningsPerLook = 20;

double follower_wall_now_s() { return ros::WallTime::now().toSec(); }

RecordFollowerSettings core_settings(const F& s) {
  RecordFollowerSettings c;
  c.path = s.path;
  c.station = s.station;
  c.sample_period_s = s.sample_period_s;
  c.ahead_tolerance_s = s.ahead_tolerance_s;
  c.ignored_path = s.state_file;
  return c;
}

}  // namespace

/// The declared parameters bound to the node's settings (formats/record_follower_settings.hpp).
const SettingBindings<F>& RecordFileFollowerSettings::bindings() {
  static const SettingBindings<F> bindings = [] {
    SettingBindings<F> b(record_file_follower_setting_declarations());
    b.bind("path", [](F& f) -> std::string& { return f.path; })
        .bind("station", [](F& f) -> std::string& { return f.station; })
        .bind("sample_period", [](F& f) -> double& { return f.sample_period_s; })
        .bind("state_file", [](F& f) -> std::string& { return f.state_file; })
        .bind("start", [](F& f) -> std::string& { return f.start; })
        .bind("ahead_tolerance", [](F& f) -> double& { return f.ahead_tolerance_s; })
        .bind("topic", [](F& f) -> std::string& { return f.topic; })
        .bind("frame_id", [](F& f) -> std::string& { return f.frame_id; })
        .bind("noise_nT", [](F& f) -> double& { return f.noise_nT; })
        .bind("follow", [](F& f) -> bool& { return f.follow; })
        .bind("poll_period", [](F& f) -> double& { return f.poll_period_s; })
        .bind("rate", [](F& f) -> double& { return f.rate; })
        .bind("wait_for_subscribers", [](F& f) -> int& { return f.wait_for_subscribers; })
        .bind("publisher_queue_size", [](F& f) -> int& { return f.publisher_queue_size; })
        .bind("max_lag", [](F& f) -> double& { return f.max_lag_s; })
        .bind("diagnostic_period", [](F& f) -> double& { return f.diagnostic_period_s; });
    return b;
  }();
  return bindings;
}

RecordFileFollowerSettings RecordFileFollowerSettings::load(const ros::NodeHandle& p) {
  RecordFileFollowerSettings s;
  load_declared(p, bindings(), s);
  if (s.path.empty()) throw ParameterError("path", "must not be empty");
  if (s.frame_id.empty()) throw ParameterError("frame_id", "must not be empty");
  if (!s.start.empty()) {
    try {
      parse_iso8601(s.start);
    } catch (const std::invalid_argument& e) {
      throw ParameterError("start", e.what());
    }
  }
  if (!s.state_file.empty()) {
    try {
      prepare_file_directory(s.state_file);
    } catch (const std::runtime_error& e) {
      throw ParameterError("state_file", e.what());
    }
  }
  return s;
}

RecordFileFollowerNode::RecordFileFollowerNode(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : nh_(nh),
      private_nh_(private_nh),
      settings_(RecordFileFollowerSettings::load(private_nh)),
      node_name_(private_nh.getNamespace()),  // the node's name; a nodelet's own name in a manager
      updater_(nh, private_nh, private_nh.getNamespace()),
      follower_(core_settings(settings_), resume_state()) {
  for (const std::string& name :
       unknown_private_parameters(private_nh_, declared_parameters(record_file_follower_setting_declarations()))) {
    ROS_WARN("%s: unknown parameter ~%s is ignored (misspelt?)", node_name_.c_str(), name.c_str());
  }
  figures_.stream = follower_.state();
  figures_.newest_published_s = follower_.state().newest_s;
  state_text_written_ = settings_.state_file.empty() ? "" : follower_state_text(follower_.state());
  publisher_ = nh_.advertise<sensor_msgs::MagneticField>(settings_.topic,
                                                         static_cast<std::uint32_t>(settings_.publisher_queue_size));
  updater_.setHardwareID("files " + settings_.path);
  updater_.add("record files", [this](diagnostic_updater::DiagnosticStatusWrapper& status) { diagnose(status); });
  diagnostic_timer_ = nh_.createWallTimer(ros::WallDuration(settings_.diagnostic_period_s),
                                          [this](const ros::WallTimerEvent&) { updater_.force_update(); });
  const double newest_s = follower_.state().newest_s;
  ROS_INFO("%s: %s %s -> %s in frame '%s' (%s, rate %s)%s", node_name_.c_str(),
           settings_.follow ? "following" : "replaying", settings_.path.c_str(),
           nh_.resolveName(settings_.topic).c_str(), settings_.frame_id.c_str(),
           settings_.follow ? ("a look every " + number_text(settings_.poll_period_s) + " s").c_str() : "once",
           number_text(settings_.rate).c_str(),
           std::isfinite(newest_s) ? (", samples after " + time_for_message(newest_s)).c_str() : "");
  worker_ = std::thread([this] { run(); });
}

RecordFileFollowerNode::~RecordFileFollowerNode() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();
  save_state();
}

RecordFollowerState RecordFileFollowerNode::resume_state() {
  RecordFollowerState state;
  if (!settings_.state_file.empty()) {
    try {
      state = read_follower_state(settings_.state_file);
    } catch (const InputError& e) {
      throw ParameterError("state_file", e.what());
    }
    if (!state.path.empty() && state.path != settings_.path) {
      ROS_WARN("%s: state file %s is of another path, '%s', not ~path '%s': not resumed", node_name_.c_str(),
               settings_.state_file.c_str(), state.path.c_str(), settings_.path.c_str());
      state = RecordFollowerState();
    }
  }
  if (!std::isfinite(state.newest_s) && !settings_.start.empty()) {
    state.newest_s = std::nextafter(parse_iso8601(settings_.start), -HUGE_VAL);  // samples at start and after
  }
  return state;
}

void RecordFileFollowerNode::run() {
  for (;;) {
    look_once(!settings_.follow);
    if (!settings_.follow) {
      std::lock_guard<std::mutex> lock(mutex_);
      figures_.replay_finished = true;
      ROS_INFO("%s: replay of %s finished: %zu samples published", node_name_.c_str(), settings_.path.c_str(),
               figures_.published);
      return;
    }
    if (!wait_until(Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                       std::chrono::duration<double>(settings_.poll_period_s)))) {
      return;
    }
  }
}

void RecordFileFollowerNode::look_once(bool final) {
  const double started_s = follower_wall_now_s();
  FollowerLook look;
  const std::size_t refused_before = follower_.counts().lines_refused();
  std::string error;
  try {
    look = follower_.look(started_s, final);
  } catch (const std::exception& e) {  // a file system error the reads do not catch, memory
    error = e.what();
    ROS_ERROR("%s: look at %s failed: %s", node_name_.c_str(), settings_.path.c_str(), e.what());
  }
  for (std::size_t i = 0; i < look.warnings.size() && i < kWarningsPerLook; ++i) {
    ROS_WARN("%s: %s", node_name_.c_str(), look.warnings[i].c_str());
  }
  if (look.warnings.size() > kWarningsPerLook) {
    ROS_WARN("%s: ... and %zu more warnings of this look", node_name_.c_str(), look.warnings.size() - kWarningsPerLook);
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    figures_.counts = follower_.counts();
    figures_.files = follower_.files();
    figures_.stream = follower_.state();
    figures_.lines_refused_last_look = follower_.counts().lines_refused() - refused_before;
    figures_.last_look_wall_s = started_s;
    figures_.last_look_duration_s = follower_wall_now_s() - started_s;
    figures_.look_error = error;
  }
  if (!look.samples.empty()) publish(look.samples);
  save_state();
}

bool RecordFileFollowerNode::publish(const VectorRecord& samples) {
  sensor_msgs::MagneticField message;
  message.header.frame_id = settings_.frame_id;
  const double variance_T2 = std::pow(settings_.noise_nT * kTeslaPerNanotesla, 2);
  for (int i = 0; i < 3; ++i) message.magnetic_field_covariance[4 * i] = variance_T2;
  Clock::time_point anchor_wall = Clock::now();
  double anchor_stamp_s = samples.time_s.front();
  state_due_ = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(kStateWritePeriod_s));
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const double t = samples.time_s[k];
    if (!(t >= 0.0 && t < 4294967296.0)) {  // before 1970 or after 2106: no ros::Time holds it
      ROS_WARN_THROTTLE(60.0, "%s: a sample stamped %s is not published: ros::Time cannot hold it", node_name_.c_str(),
                        time_for_message(t).c_str());
      continue;
    }
    if (publisher_.getNumSubscribers() < static_cast<std::uint32_t>(settings_.wait_for_subscribers)) {
      if (!wait_for_subscribers()) return false;
      anchor_wall = Clock::now();  // the pace starts again from here
      anchor_stamp_s = t;
    }
    if (settings_.rate > 0.0) {
      const auto due = anchor_wall + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>((t - anchor_stamp_s) / settings_.rate));
      if (due > Clock::now() && !wait_until(due)) return false;
    } else {
      std::lock_guard<std::mutex> lock(mutex_);
      if (stopping_) return false;
    }
    if (!ros::ok()) return false;  // shutting down: not published, not counted
    message.header.stamp = ros::Time().fromSec(t);
    const auto row = static_cast<Eigen::Index>(k);
    message.magnetic_field.x = samples.values_nT(row, 0) * kTeslaPerNanotesla;
    message.magnetic_field.y = samples.values_nT(row, 1) * kTeslaPerNanotesla;
    message.magnetic_field.z = samples.values_nT(row, 2) * kTeslaPerNanotesla;
    publisher_.publish(message);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++figures_.published;
      figures_.newest_published_s = t;
    }
    if (Clock::now() >= state_due_) {
      save_state();
      state_due_ = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(kStateWritePeriod_s));
    }
  }
  return true;
}

bool RecordFileFollowerNode::wait_for_subscribers() {
  const auto wanted = static_cast<std::uint32_t>(settings_.wait_for_subscribers);
  std::unique_lock<std::mutex> lock(mutex_);
  figures_.waiting_for_subscribers = true;
  while (publisher_.getNumSubscribers() < wanted) {
    if (stopping_ || !ros::ok()) break;
    wake_.wait_for(lock, std::chrono::milliseconds(50));
  }
  figures_.waiting_for_subscribers = false;
  return !stopping_ && ros::ok();
}

bool RecordFileFollowerNode::wait_until(Clock::time_point until) {
  std::unique_lock<std::mutex> lock(mutex_);
  return !wake_.wait_until(lock, until, [this] { return stopping_; });
}

void RecordFileFollowerNode::save_state() {
  if (settings_.state_file.empty()) return;
  RecordFollowerState state = follower_.state();  // the stream's station, period and components
  {
    std::lock_guard<std::mutex> lock(mutex_);
    state.newest_s = figures_.newest_published_s;  // published, not only handed out
  }
  const std::string text = follower_state_text(state);
  if (text == state_text_written_) return;
  std::string error;
  try {
    write_file_atomically(settings_.state_file, text);
    state_text_written_ = text;
  } catch (const std::runtime_error& e) {
    error = e.what();
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (!error.empty() && figures_.state_error.empty()) {
    ROS_ERROR("%s: state file not written: %s", node_name_.c_str(), error.c_str());
  }
  figures_.state_error = error;
  if (error.empty()) figures_.state_written = time_for_message(follower_wall_now_s());
}

}  // namespace magnetometer_insitu_calibration
