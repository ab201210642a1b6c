// calibration_node: sliding-window in-situ calibration (see calibration_node.hpp).
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"

#include "magnetometer_insitu_calibration/estimation/calibration_change.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"
#include "magnetometer_insitu_calibration/ros/parameters.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <sys/stat.h>
#include <sstream>

namespace magnetometer_insitu_calibration {

namespace {

using diagnostic_msgs::DiagnosticStatus;
using diagnostic_updater::DiagnosticStatusWrapper;

constexpr double kNanoteslaPerTesla = 1e9;
constexpr double kZ95 = 1.959963984540054;  // two-sided 95 % normal quantile

static_assert(static_cast<int>(Quality::kOk) == MagnetometerCalibration::QUALITY_OK &&
                  static_cast<int>(Quality::kTooFewSamples) == MagnetometerCalibration::QUALITY_TOO_FEW_SAMPLES &&
                  static_cast<int>(Quality::kTooFewHarmonics) == MagnetometerCalibration::QUALITY_TOO_FEW_HARMONICS &&
                  static_cast<int>(Quality::kIllConditioned) == MagnetometerCalibration::QUALITY_ILL_CONDITIONED &&
                  static_cast<int>(Quality::kLowCoherence) == MagnetometerCalibration::QUALITY_LOW_COHERENCE &&
                  static_cast<int>(Quality::kGaps) == MagnetometerCalibration::QUALITY_GAPS &&
                  static_cast<int>(Quality::kNotFinite) == MagnetometerCalibration::QUALITY_NOT_FINITE,
              "Quality and the message's QUALITY_* constants must agree");

void add_counters(PairingCounters& total, const PairingCounters& more) {
  total.paired += more.paired;
  total.unpaired_reference += more.unpaired_reference;
  total.unpaired_test += more.unpaired_test;
  total.late += more.late;
  total.duplicates += more.duplicates;
  total.invalid += more.invalid;
}

Eigen::Vector3d nanotesla(const sensor_msgs::MagneticField& message) {
  return kNanoteslaPerTesla *
         Eigen::Vector3d(message.magnetic_field.x, message.magnetic_field.y, message.magnetic_field.z);
}

template <typename Array>
void copy3(Array& out, const Eigen::Vector3d& v) {
  for (int i = 0; i < 3; ++i) out[i] = v(i);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Channel: one test instrument

struct CalibrationNode::Channel {
  Channel(const TestInstrumentSettings& s, const CalibrationNodeSettings& node)
      : settings(s),
        pairer(node.pairing_tolerance_s, node.pairing_max_wait_s),
        windows(node.window_s, node.step_s, node.estimation_period_s()) {
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
  // Change check: the accepted calibration the sliding windows are compared with (the first
  // window accepted since start, or the calibration file loaded at start).
  std::unique_ptr<WindowEstimate> baseline;
  std::string baseline_window, baseline_source = "none";
  bool change_checked = false;
  CalibrationChange last_change;
  std::string last_change_window;
  std::size_t changes_detected = 0;
  std::string resume_state = "not tried";

  PairingCounters counters() const {
    PairingCounters total = counters_before_reset;
    add_counters(total, pairer.counters());
    return total;
  }
};

// ---------------------------------------------------------------------------------------------
// Node

CalibrationNode::CalibrationNode(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : nh_(nh),
      private_nh_(private_nh),
      settings_(CalibrationNodeSettings::load(private_nh)),
      node_name_(ros::this_node::getName()),
      updater_(nh, private_nh) {
  for (const std::string& name : unknown_private_parameters(private_nh_, CalibrationNodeSettings::known_parameters())) {
    ROS_WARN("%s: unknown parameter ~%s is ignored (misspelt?)", node_name_.c_str(), name.c_str());
  }
  reference_.topic = settings_.reference_topic;
  ros::TransportHints hints = ros::TransportHints().tcpNoDelay();
  updater_.setHardwareID("reference " + nh_.resolveName(settings_.reference_topic));
  updater_.add("reference", [this](DiagnosticStatusWrapper& status) { diagnose_reference(status); });
  for (std::size_t i = 0; i < settings_.tests.size(); ++i) {
    const TestInstrumentSettings& t = settings_.tests[i];
    channels_.push_back(std::make_unique<Channel>(t, settings_));
    Channel& ch = *channels_.back();
    ch.test.topic = t.topic;
    ch.publisher = nh_.advertise<MagnetometerCalibration>(t.calibration_topic, 10, /*latch=*/true);
    ch.subscriber = nh_.subscribe<sensor_msgs::MagneticField>(
        t.topic, static_cast<std::uint32_t>(settings_.queue_size),
        boost::function<void(const sensor_msgs::MagneticField::ConstPtr&)>(
            [this, i](const sensor_msgs::MagneticField::ConstPtr& m) { on_test(i, m); }),
        ros::VoidConstPtr(), hints);
    resume_from_file(ch);
    updater_.add(t.name, [this, i](DiagnosticStatusWrapper& status) { diagnose_channel(i, status); });
    ROS_INFO("%s: test '%s' on %s -> %s, file %s", node_name_.c_str(), t.name.c_str(), nh_.resolveName(t.topic).c_str(),
             nh_.resolveName(t.calibration_topic).c_str(), t.calibration_file.c_str());
  }
  reference_subscriber_ = nh_.subscribe(settings_.reference_topic, static_cast<std::uint32_t>(settings_.queue_size),
                                        &CalibrationNode::on_reference, this, hints);
  ROS_INFO("%s: reference %s; window %g s every %g s at %g s (%s); band %g-%g Hz%s; method %s", node_name_.c_str(),
           nh_.resolveName(settings_.reference_topic).c_str(), settings_.window_s, settings_.step_s,
           settings_.estimation_period_s(),
           settings_.decimating() ? "low-passed and decimated" : "input rate", settings_.estimator.band_low_hz,
           settings_.estimator.band_high_hz, settings_.estimator.robust.auto_band ? " (auto band)" : "",
           estimator_method_name(settings_.estimator.method));
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

void CalibrationNode::reset_pipeline(Channel& ch) {
  add_counters(ch.counters_before_reset, ch.pairer.counters());
  ch.pairer.reset();
  if (ch.reference_decimator) {
    ch.reference_decimator->reset();
    ch.test_decimator->reset();
  }
  ch.windows.reset();
  ch.any_pair = false;
  ++ch.pipeline_resets;
  ROS_WARN("%s: test '%s': stamps went backwards, pairing and window restarted", node_name_.c_str(),
           ch.settings.name.c_str());
}

void CalibrationNode::drain_pairs(std::size_t index) {
  Channel& ch = *channels_[index];
  for (const PairedSample& pair : ch.pairer.take_pairs()) {
    auto feed = [&](double t, const Eigen::Vector3d& r, const Eigen::Vector3d& s) {
      for (WindowData& w : ch.windows.push(t, r, s)) enqueue(index, std::move(w));
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

void CalibrationNode::enqueue(std::size_t index, WindowData&& window) {
  Job job;
  job.channel = index;
  job.window = std::move(window);
  job.reference_frame_id = reference_.frame_id;
  job.test_frame_id = channels_[index]->test.frame_id;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    if (queue_.size() >= static_cast<std::size_t>(settings_.max_pending_windows)) {
      ++channels_[queue_.front().channel]->dropped_busy;
      queue_.pop_front();
    }
    queue_.push_back(std::move(job));
  }
  queue_cv_.notify_one();
}

void CalibrationNode::resume_from_file(Channel& ch) {
  const TestInstrumentSettings& t = ch.settings;
  struct stat info {};
  if (::stat(t.calibration_file.c_str(), &info) != 0) {
    ch.resume_state = "no calibration file at start";
    return;
  }
  try {
    MagnetometerCalibration m = load_calibration_file(t.calibration_file);
    std::string reason;
    if (!m.accepted || m.quality != MagnetometerCalibration::QUALITY_OK) reason = "not an accepted calibration";
    if (reason.empty() && m.test_name != t.name) reason = "written for test '" + m.test_name + "'";
    auto e = std::make_unique<WindowEstimate>();
    for (int k = 0; k < 9; ++k) e->n(k / 3, k % 3) = m.matrix[k];
    for (int k = 0; k < 81; ++k) e->n_covariance(k / 9, k % 9) = m.matrix_covariance[k];
    if (reason.empty() && !(e->n.allFinite() && e->n_covariance.allFinite())) reason = "matrix or covariance not finite";
    if (!reason.empty()) {
      ch.resume_state = "calibration file not resumed: " + reason;
      ROS_WARN("%s: test '%s': %s (%s)", node_name_.c_str(), t.name.c_str(), ch.resume_state.c_str(),
               t.calibration_file.c_str());
      return;
    }
    e->samples = m.samples;
    e->sample_period_s = m.sample_period;
    e->quality = Quality::kOk;
    e->method = m.method;
    e->parameters = decompose(e->n, e->n_covariance);
    const std::string window = time_for_message(m.window_start.toSec()) + " .. " + time_for_message(m.window_end.toSec());
    ch.baseline = std::move(e);
    ch.baseline_window = window;
    ch.baseline_source = "file (loaded at start)";
    ch.last_accepted_window = window;
    ch.last_accepted_stamp = time_for_message(m.header.stamp.toSec());
    ch.resume_state = "resumed from file";
    ch.publisher.publish(m);  // latched: subscribers get the persisted calibration at once
    ROS_INFO("%s: test '%s': resumed the accepted calibration of window %s from %s", node_name_.c_str(),
             t.name.c_str(), window.c_str(), t.calibration_file.c_str());
  } catch (const std::exception& error) {
    ch.resume_state = std::string("calibration file not resumed: ") + error.what();
    ROS_WARN("%s: test '%s': %s", node_name_.c_str(), t.name.c_str(), ch.resume_state.c_str());
  }
}

void CalibrationNode::run_worker() {
  WindowEstimator estimator(settings_.estimator);  // this thread's own (FFTW plans and buffers)
  for (;;) {
    Job job;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      queue_cv_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      job = std::move(queue_.front());
      queue_.pop_front();
    }
    process(job, estimator);
  }
}

void CalibrationNode::process(Job& job, WindowEstimator& estimator) {
  Channel& ch = *channels_[job.channel];
  const TestInstrumentSettings& t = ch.settings;
  const double period = job.window.period_s;
  const double nominal_start = job.window.start_s, nominal_end = job.window.end_s();
  const std::string window_text = time_for_message(nominal_start) + " .. " + time_for_message(nominal_end);
  const auto started = std::chrono::steady_clock::now();
  WindowResult result;
  try {
    result = estimate_window(std::move(job.window), estimator, settings_.gap_rule);
  } catch (const std::exception& e) {
    ROS_ERROR("%s: test '%s': window %s could not be prepared: %s", node_name_.c_str(), t.name.c_str(),
              window_text.c_str(), e.what());
    std::lock_guard<std::mutex> lock(ch.results_mutex);
    ++ch.failed;
    ch.last_failed = true;
    ch.last_failure = window_text + ": " + e.what();
    return;
  }
  const WindowEstimate& e = result.estimate;
  MagnetometerCalibration m;
  m.header.stamp = ros::Time::now();
  m.header.frame_id = job.reference_frame_id;
  m.test_name = t.name;
  m.reference_frame_id = job.reference_frame_id;
  m.test_frame_id = job.test_frame_id;
  m.window_start = ros::Time().fromSec(result.start_s);
  m.window_end = ros::Time().fromSec(result.end_s);
  m.sample_period = period;
  m.samples = static_cast<std::uint32_t>(e.samples);
  m.filled_samples = static_cast<std::uint32_t>(result.missing());
  m.band_low_hz = settings_.estimator.band_low_hz;
  m.band_high_hz = settings_.estimator.band_high_hz;
  m.harmonic_first = static_cast<std::uint32_t>(std::max(0, e.harmonic_first));
  m.harmonic_last = static_cast<std::uint32_t>(std::max(0, e.harmonic_last));
  m.gamma = settings_.estimator.gamma;
  m.trend_column = settings_.estimator.trend;
  m.method = e.method;
  m.band_used_low_hz = e.band_low_hz;
  m.band_used_high_hz = e.band_high_hz;
  m.delay_s = e.delay_s;
  m.delay_ci95_s = e.delay_ci95_s;
  copy3(m.offset_nT, result.offset_end_nT);
  copy3(m.reference_mean_nT, result.reference_mean_nT);
  copy3(m.offset_ci95_nT, result.offset_end_ci95_nT);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m.matrix[vec_index(r, c)] = e.n(r, c);
  }
  for (int r = 0; r < 9; ++r) {
    for (int c = 0; c < 9; ++c) m.matrix_covariance[9 * r + c] = e.n_covariance(r, c);
  }
  copy3(m.trend_nT_per_day, e.trend_nT_per_day);
  copy3(m.trend_ci95_nT_per_day, kZ95 * e.trend_stderr_nT_per_day);
  const CalibrationParameters& p = e.parameters;
  copy3(m.scale_ratio, p.scale_ratio);
  copy3(m.scale_ratio_ci95, p.scale_ratio_ci95);
  copy3(m.nonorthogonality_deg, p.nonorthogonality_deg);
  copy3(m.nonorthogonality_ci95_deg, p.nonorthogonality_ci95_deg);
  copy3(m.misalignment_deg, p.misalignment_deg);
  copy3(m.misalignment_ci95_deg, p.misalignment_ci95_deg);
  copy3(m.axis_deviation_deg, p.axis_deviation_deg);
  copy3(m.axis_deviation_ci95_deg, p.axis_deviation_ci95_deg);
  m.condition_number = e.condition_number;
  copy3(m.coherence, e.coherence);
  copy3(m.residual_rms_nT, e.residual_rms_nT);
  m.quality = static_cast<std::uint8_t>(e.quality);
  m.quality_text = e.quality_text;
  if (e.quality == Quality::kOk && !(e.n.allFinite() && e.n_covariance.allFinite())) {
    m.quality = MagnetometerCalibration::QUALITY_NOT_FINITE;
    m.quality_text = "matrix or covariance not finite";
  }
  if (m.quality == MagnetometerCalibration::QUALITY_OK && !result.offset_end_nT.allFinite()) {
    m.quality = MagnetometerCalibration::QUALITY_NOT_FINITE;
    m.quality_text = "offset not finite";
  }
  m.accepted = m.quality == MagnetometerCalibration::QUALITY_OK;

  // The file first, so that whoever sees the accepted message finds it on disk.
  std::string file_error;
  if (m.accepted) {
    try {
      write_file_atomically(t.calibration_file, calibration_to_yaml(m, node_name_));
    } catch (const std::exception& error) {
      file_error = error.what();
      ROS_ERROR("%s: test '%s': calibration file not written: %s", node_name_.c_str(), t.name.c_str(), error.what());
    }
  }
  ch.publisher.publish(m);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  ROS_INFO("%s: test '%s': window %s: %s (%s; %u samples, %u missing; %.3f s)", node_name_.c_str(), t.name.c_str(),
           window_text.c_str(), m.accepted ? "accepted" : "rejected", m.quality_text.c_str(), m.samples,
           m.filled_samples, seconds);

  std::lock_guard<std::mutex> lock(ch.results_mutex);
  // Change check of this window against the accepted calibration (before it may become it).
  if (ch.baseline) {
    ch.last_change = check_calibration_change(*ch.baseline, e, settings_.change);
    ch.last_change_window = window_text;
    ch.change_checked = true;
    if (ch.last_change.status == CalibrationChangeStatus::kChanged) {
      ++ch.changes_detected;
      ROS_WARN("%s: test '%s': window %s: %s", node_name_.c_str(), t.name.c_str(), window_text.c_str(),
               ch.last_change.text.c_str());
    }
  } else if (m.accepted) {
    ch.baseline = std::make_unique<WindowEstimate>(e);
    ch.baseline_window = window_text;
    ch.baseline_source = "first window accepted since start";
  }
  {
    std::ostringstream band, offset;
    band << m.band_used_low_hz << " .. " << m.band_used_high_hz;
    offset.precision(6);
    for (int k = 0; k < 3; ++k) offset << (k ? " " : "") << m.offset_nT[k];
    offset << " (95 % +-";
    for (int k = 0; k < 3; ++k) offset << " " << m.offset_ci95_nT[k];
    offset << ")";
    ch.last_band = band.str();
    ch.last_offset = offset.str();
  }
  ch.last_method = m.method;
  ch.last_eiv = e.eiv;
  ch.last_delay_s = m.delay_s;
  ch.last_delay_ci95_s = m.delay_ci95_s;
  ++ch.estimated;
  ch.last_failed = false;
  ch.last_window = window_text;
  ch.last_quality = std::string(quality_name(static_cast<Quality>(m.quality))) + ": " + m.quality_text;
  ch.last_accepted = m.accepted;
  ch.last_duration_s = seconds;
  if (m.accepted) {
    ++ch.accepted;
    ch.last_accepted_window = window_text;
    ch.last_accepted_stamp = time_for_message(m.header.stamp.toSec());
    ch.file_error = file_error;
    if (file_error.empty()) ++ch.files_written;
  } else {
    ++ch.flagged;
  }
}

// ---------------------------------------------------------------------------------------------
// Diagnostics

void CalibrationNode::diagnose_reference(DiagnosticStatusWrapper& status) {
  const double now = ros::Time::now().toSec();
  if (started_s_ == 0.0 && now > 0.0) started_s_ = now;
  status.summary(DiagnosticStatus::OK, "receiving");
  status.add("topic", nh_.resolveName(reference_.topic));
  status.add("frame_id", reference_.frame_id);
  status.add("messages", reference_.messages);
  status.add("newest stamp", reference_.messages > 0 ? time_for_message(reference_.newest_stamp_s) : std::string("none"));
  status.add("stamp jumps forward", reference_.jumps_forward);
  status.add("stamp jumps backward", reference_.jumps_backward);
  status.add("stray stamps", reference_.stray);
  const double silence = reference_.silence_s(now, started_s_);
  status.add("silent for (s)", silence);
  if (started_s_ > 0.0 && silence > settings_.silent_timeout_s) {
    status.mergeSummary(DiagnosticStatus::WARN, reference_.messages > 0
                                                    ? "reference topic silent for " + number_text(std::round(silence)) + " s"
                                                    : "no reference message yet");
  }
}

void CalibrationNode::diagnose_channel(std::size_t index, DiagnosticStatusWrapper& status) {
  Channel& ch = *channels_[index];
  const double now = ros::Time::now().toSec();
  if (started_s_ == 0.0 && now > 0.0) started_s_ = now;
  status.summary(DiagnosticStatus::OK, "ok");
  std::vector<std::pair<unsigned char, std::string>> problems;

  status.add("test topic", nh_.resolveName(ch.test.topic));
  status.add("calibration topic", nh_.resolveName(ch.settings.calibration_topic));
  status.add("calibration file", ch.settings.calibration_file);
  status.add("test frame_id", ch.test.frame_id);
  status.add("test messages", ch.test.messages);
  status.add("test newest stamp", ch.test.messages > 0 ? time_for_message(ch.test.newest_stamp_s) : std::string("none"));
  status.add("test stamp jumps forward", ch.test.jumps_forward);
  status.add("test stamp jumps backward", ch.test.jumps_backward);
  status.add("test stray stamps", ch.test.stray);
  const double silence = ch.test.silence_s(now, started_s_);
  status.add("test silent for (s)", silence);
  if (started_s_ > 0.0 && silence > settings_.silent_timeout_s) {
    problems.emplace_back(DiagnosticStatus::WARN, ch.test.messages > 0
                                                      ? "test topic silent for " + number_text(std::round(silence)) + " s"
                                                      : "no test message yet");
  }

  const PairingCounters c = ch.counters();
  status.add("paired", c.paired);
  status.add("unpaired reference", c.unpaired_reference);
  status.add("unpaired test", c.unpaired_test);
  status.add("late", c.late);
  status.add("duplicates", c.duplicates);
  status.add("invalid stamps", c.invalid);
  status.add("pending reference", ch.pairer.pending_reference());
  status.add("pending test", ch.pairer.pending_test());
  if (c.late > ch.reported_late || c.duplicates > ch.reported_duplicates) {
    problems.emplace_back(DiagnosticStatus::WARN, std::to_string(c.late - ch.reported_late) + " late and " +
                                                      std::to_string(c.duplicates - ch.reported_duplicates) +
                                                      " duplicate samples since the last report");
  }
  ch.reported_late = c.late;
  ch.reported_duplicates = c.duplicates;
  status.add("decimating", settings_.decimating());
  status.add("decimator restarts", ch.decimator_restarts);
  status.add("pipeline resets (stamps backwards)", ch.pipeline_resets);
  status.add("buffered samples", ch.windows.buffered());
  status.add("windows queued", ch.windows.windows_emitted());
  status.add("windows skipped (no data)", ch.windows.windows_skipped_empty());
  const std::size_t dropped = ch.dropped_busy.load();
  status.add("windows dropped (worker busy)", dropped);
  if (dropped > ch.reported_dropped) {
    problems.emplace_back(DiagnosticStatus::WARN, std::to_string(dropped - ch.reported_dropped) +
                                                      " windows dropped: estimator busy");
  }
  ch.reported_dropped = dropped;
  {
    std::size_t pending = 0;
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      for (const Job& job : queue_) pending += job.channel == index;
    }
    status.add("windows pending", pending);
  }
  {
    std::lock_guard<std::mutex> lock(ch.results_mutex);
    status.add("windows estimated", ch.estimated);
    status.add("windows accepted", ch.accepted);
    status.add("windows flagged", ch.flagged);
    status.add("windows failed", ch.failed);
    status.add("last window", ch.last_window.empty() ? std::string("none") : ch.last_window);
    status.add("last window quality", ch.last_quality);
    status.add("last window accepted", ch.last_accepted);
    status.add("last estimate duration (s)", ch.last_duration_s);
    status.add("last accepted window", ch.last_accepted_window.empty() ? std::string("none") : ch.last_accepted_window);
    status.add("last accepted stamp", ch.last_accepted_stamp);
    status.add("calibration files written", ch.files_written);
    status.add("method", ch.last_method.empty() ? estimator_method_name(settings_.estimator.method) : ch.last_method);
    status.add("EIV (last window)", ch.last_eiv.empty() ? std::string("no window yet") : ch.last_eiv);
    status.add("last band used (Hz)", ch.last_band);
    status.add("last delay (s)", ch.last_delay_s);
    status.add("last delay ci95 (s)", ch.last_delay_ci95_s);
    status.add("last offset at window end (nT)", ch.last_offset);
    status.add("resume at start", ch.resume_state);
    status.add("loaded from file", ch.resume_state == "resumed from file");
    status.add("accepted calibration (change check)", ch.baseline ? ch.baseline_window : std::string("none"));
    status.add("accepted calibration source", ch.baseline_source);
    status.add("calibration changes detected", ch.changes_detected);
    if (ch.change_checked) {
      status.add("change check window", ch.last_change_window);
      status.add("change status", calibration_change_status_name(ch.last_change.status));
      status.add("change chi2 (9 dof)", ch.last_change.chi2);
      status.add("change p-value", ch.last_change.p_value);
      status.add("change max z (scale)", ch.last_change.scale_z.maxCoeff());
      status.add("change max z (nonorthogonality)", ch.last_change.nonorthogonality_z.maxCoeff());
      status.add("change max z (misalignment)", ch.last_change.misalignment_z.maxCoeff());
      status.add("change text", ch.last_change.text);
      if (ch.last_change.status == CalibrationChangeStatus::kChanged) {
        problems.emplace_back(DiagnosticStatus::WARN, "calibration changed: " + ch.last_change.text);
      }
    }
    status.add("calibration file error", ch.file_error);
    if (ch.last_failed) problems.emplace_back(DiagnosticStatus::ERROR, "window failed: " + ch.last_failure);
    if (!ch.file_error.empty()) problems.emplace_back(DiagnosticStatus::ERROR, "file not written: " + ch.file_error);
    if (ch.estimated > 0 && !ch.last_accepted && !ch.last_failed) {
      problems.emplace_back(DiagnosticStatus::WARN, "last window rejected (" + ch.last_quality + ")");
    }
  }
  for (const auto& problem : problems) status.mergeSummary(problem.first, problem.second);
}

}  // namespace magnetometer_insitu_calibration
