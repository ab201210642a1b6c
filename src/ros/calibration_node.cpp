// calibration_node: sliding-window in-situ calibration (see calibration_node.hpp).
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"

#include "magnetometer_insitu_calibration/calibration_change.hpp"
#include "magnetometer_insitu_calibration/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/input_error.hpp"
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"
#include "magnetometer_insitu_calibration/ros/parameters.hpp"
#include "magnetometer_insitu_calibration/time_format.hpp"

#include <ros/names.h>

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

// Every private parameter of the node (others draw a start-up warning).
const std::vector<std::string> kKnownParameters = {
    "reference_topic", "test_topic", "test_name", "calibration_topic", "calibration_file", "tests",
    "input_period", "output_period", "decimation_sigma", "decimation_half_width", "pairing_tolerance",
    "pairing_max_wait", "window", "step", "max_filled_fraction", "max_fill", "band_low", "band_high",
    "gamma", "trend", "min_harmonics", "max_condition_number", "min_coherence", "silent_timeout",
    "time_jump_threshold", "queue_size", "max_pending_windows", "diagnostic_period", "method", "auto_band", "eiv",
    "eiv_noise_ratio", "estimate_delay", "correct_delay", "change_false_alarm_probability", "change_scale_tolerance",
    "change_angle_tolerance"};

// Core field names (InputError::where) -> the parameter that sets them.
const std::map<std::string, std::string> kCoreFieldToParameter = {
    {"band_low_hz", "band_low"}, {"band_high_hz", "band_high"}, {"gamma", "gamma"},
    {"min_harmonics", "min_harmonics"}, {"max_condition_number", "max_condition_number"},
    {"min_coherence", "min_coherence"}, {"output_period_s", "output_period"}, {"sigma_s", "decimation_sigma"},
    {"half_width_sigmas", "decimation_half_width"}, {"input_period_s", "input_period"},
    {"tolerance_s", "pairing_tolerance"}, {"max_wait_s", "pairing_max_wait"}, {"window", "window"},
    {"step", "step"}, {"max_fill_s", "max_fill"}, {"max_filled_fraction", "max_filled_fraction"},
    {"eiv_noise_ratio", "eiv_noise_ratio"}, {"false_alarm_probability", "change_false_alarm_probability"},
    {"scale_tolerance", "change_scale_tolerance"}, {"angle_tolerance_deg", "change_angle_tolerance"}};

std::string text_of(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

std::string iso(double unix_s) {
  try {
    return format_iso8601(unix_s, 3);
  } catch (const std::exception&) {
    return text_of(unix_s);
  }
}

void check_topic(const std::string& parameter, const std::string& topic) {
  std::string error;
  if (!ros::names::validate(topic, error)) throw ParameterError(parameter, "'" + topic + "' is not a valid topic name: " + error);
}

std::string struct_string(XmlRpc::XmlRpcValue& entry, const std::string& key, const std::string& where, bool required,
                          const std::string& fallback) {
  if (!entry.hasMember(key)) {
    if (required) throw ParameterError(where + "." + key, "is required and not set");
    return fallback;
  }
  if (entry[key].getType() != XmlRpc::XmlRpcValue::TypeString) throw ParameterError(where + "." + key, "must be a string");
  const std::string value = static_cast<std::string>(entry[key]);
  if (value.empty()) throw ParameterError(where + "." + key, "must not be empty");
  return value;
}

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
// Settings

CalibrationNodeSettings CalibrationNodeSettings::load(const ros::NodeHandle& p) {
  CalibrationNodeSettings s;
  s.reference_topic = required_string(p, "reference_topic");
  check_topic("reference_topic", s.reference_topic);

  const bool has_list = p.hasParam("tests"), has_single = p.hasParam("test_topic");
  if (has_list && has_single) throw ParameterError("tests", "give either ~tests (a list) or ~test_topic, not both");
  if (!has_list && !has_single) throw ParameterError("test_topic", "is required and not set (or give a ~tests list)");
  if (has_single) {
    TestInstrumentSettings t;
    t.topic = required_string(p, "test_topic");
    t.name = param_string(p, "test_name", "test");
    if (t.name.empty()) throw ParameterError("test_name", "must not be empty");
    t.calibration_topic = param_string(p, "calibration_topic", "calibration");
    if (t.calibration_topic.empty()) throw ParameterError("calibration_topic", "must not be empty");
    t.calibration_file = required_string(p, "calibration_file");
    check_topic("test_topic", t.topic);
    check_topic("calibration_topic", t.calibration_topic);
    s.tests.push_back(t);
  } else {
    for (const char* single_only : {"test_name", "calibration_topic", "calibration_file"}) {
      if (p.hasParam(single_only)) {
        throw ParameterError(single_only, "belongs to the single-instrument form (~test_topic); with ~tests give it per entry");
      }
    }
    XmlRpc::XmlRpcValue list;
    p.getParam("tests", list);
    if (list.getType() != XmlRpc::XmlRpcValue::TypeArray || list.size() == 0) {
      throw ParameterError("tests", "must be a non-empty list of {name, topic, calibration_file, calibration_topic (optional)}");
    }
    for (int i = 0; i < list.size(); ++i) {
      const std::string where = "tests[" + std::to_string(i) + "]";
      XmlRpc::XmlRpcValue& entry = list[i];
      if (entry.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
        throw ParameterError(where, "must be a map {name, topic, calibration_file, calibration_topic (optional)}");
      }
      for (const auto& member : entry) {
        if (member.first != "name" && member.first != "topic" && member.first != "calibration_topic" &&
            member.first != "calibration_file") {
          throw ParameterError(where + "." + member.first, "unknown key (name, topic, calibration_topic, calibration_file)");
        }
      }
      TestInstrumentSettings t;
      t.name = struct_string(entry, "name", where, true, "");
      t.topic = struct_string(entry, "topic", where, true, "");
      t.calibration_topic = struct_string(entry, "calibration_topic", where, false, t.name + "/calibration");
      t.calibration_file = struct_string(entry, "calibration_file", where, true, "");
      check_topic(where + ".topic", t.topic);
      check_topic(where + ".calibration_topic", t.calibration_topic);
      s.tests.push_back(t);
    }
  }
  std::set<std::string> names, topics{s.reference_topic}, outputs, files;
  for (std::size_t i = 0; i < s.tests.size(); ++i) {
    const std::string where = has_list ? "tests[" + std::to_string(i) + "]." : "";
    const TestInstrumentSettings& t = s.tests[i];
    if (!names.insert(t.name).second) throw ParameterError(where + "name", "'" + t.name + "' is used twice");
    if (!topics.insert(t.topic).second) {
      throw ParameterError(where + (has_list ? "topic" : "test_topic"), "'" + t.topic + "' is the reference topic or used twice");
    }
    if (!outputs.insert(t.calibration_topic).second) {
      throw ParameterError(where + "calibration_topic", "'" + t.calibration_topic + "' is used twice");
    }
    if (!files.insert(t.calibration_file).second) {
      throw ParameterError(where + "calibration_file", "'" + t.calibration_file + "' is used twice");
    }
  }

  // Periods and decimation.
  s.input_period_s = param_double(p, "input_period", s.input_period_s);
  require_positive("input_period", s.input_period_s, "s");
  s.decimation.output_period_s = param_double(p, "output_period", s.decimation.output_period_s);
  require_positive("output_period", s.decimation.output_period_s, "s");
  s.decimation.sigma_s = param_double(p, "decimation_sigma", s.decimation.sigma_s);
  require_non_negative("decimation_sigma", s.decimation.sigma_s, "s (0 = default)");
  s.decimation.half_width_sigmas = param_double(p, "decimation_half_width", s.decimation.half_width_sigmas);
  require_positive("decimation_half_width", s.decimation.half_width_sigmas, "sigmas");
  const double period = s.estimation_period_s();

  // Pairing.
  s.pairing_tolerance_s = param_double(p, "pairing_tolerance", s.pairing_tolerance_s);
  require_non_negative("pairing_tolerance", s.pairing_tolerance_s, "s");
  if (!(s.pairing_tolerance_s < 0.5 * s.input_period_s)) {
    throw ParameterError("pairing_tolerance", "must be below half of ~input_period (" + text_of(0.5 * s.input_period_s) +
                                                  " s): a sample could pair with its partner's neighbour");
  }
  s.pairing_max_wait_s = param_double(p, "pairing_max_wait", s.pairing_max_wait_s);
  require_non_negative("pairing_max_wait", s.pairing_max_wait_s, "s");

  // Windows.
  s.window_s = param_double(p, "window", s.window_s);
  require_positive("window", s.window_s, "s");
  s.step_s = param_double(p, "step", s.step_s);
  require_positive("step", s.step_s, "s");
  if (s.step_s > s.window_s) {
    throw ParameterError("step", "(" + text_of(s.step_s) + " s) is longer than ~window (" + text_of(s.window_s) +
                                     " s): samples between windows would never be used");
  }
  if (s.step_s < period) throw ParameterError("step", "must be at least one sample period (" + text_of(period) + " s)");
  s.gap_rule.max_filled_fraction = param_double(p, "max_filled_fraction", s.gap_rule.max_filled_fraction);
  require_in_range("max_filled_fraction", s.gap_rule.max_filled_fraction, 0.0, 1.0);
  s.gap_rule.gaps.max_fill_s = param_double(p, "max_fill", s.gap_rule.gaps.max_fill_s);
  require_non_negative("max_fill", s.gap_rule.gaps.max_fill_s, "s");

  // Estimator.
  s.estimator.band_low_hz = param_double(p, "band_low", s.estimator.band_low_hz);
  require_positive("band_low", s.estimator.band_low_hz, "Hz");
  s.estimator.band_high_hz = param_double(p, "band_high", s.estimator.band_high_hz);
  if (!(s.estimator.band_high_hz > s.estimator.band_low_hz)) {
    throw ParameterError("band_high", "(" + text_of(s.estimator.band_high_hz) + " Hz) must be above ~band_low (" +
                                          text_of(s.estimator.band_low_hz) + " Hz): the band is empty");
  }
  if (s.estimator.band_high_hz > 0.5 / period) {
    throw ParameterError("band_high", "(" + text_of(s.estimator.band_high_hz) + " Hz) is above the Nyquist frequency " +
                                          text_of(0.5 / period) + " Hz of the " + text_of(period) + " s estimation period");
  }
  s.estimator.gamma = param_double(p, "gamma", s.estimator.gamma);
  s.estimator.trend = param_bool(p, "trend", s.estimator.trend);
  const int min_harmonics = param_int(p, "min_harmonics", static_cast<int>(s.estimator.min_harmonics));
  if (min_harmonics < 1) throw ParameterError("min_harmonics", "must be >= 1");
  s.estimator.min_harmonics = static_cast<std::size_t>(min_harmonics);
  s.estimator.max_condition_number = param_double(p, "max_condition_number", s.estimator.max_condition_number);
  s.estimator.min_coherence = param_double(p, "min_coherence", s.estimator.min_coherence);
  // The offline CLI's estimator (robust_estimator.hpp): method and the options that matter live.
  try {
    s.estimator.method = parse_estimator_method(param_string(p, "method", "robust"), "method");
    s.estimator.robust.eiv = parse_eiv_correction(param_string(p, "eiv", "ratio"), "eiv");
  } catch (const InputError& e) {
    throw ParameterError(e.where(), e.problem());
  }
  if (s.estimator.robust.eiv == EivCorrection::kGiven) {
    throw ParameterError("eiv", "'given' needs the reference noise spectrum, which the node does not take: use none or ratio");
  }
  s.estimator.robust.auto_band = param_bool(p, "auto_band", s.estimator.robust.auto_band);
  s.estimator.robust.eiv_noise_ratio = param_double(p, "eiv_noise_ratio", s.estimator.robust.eiv_noise_ratio);
  require_non_negative("eiv_noise_ratio", s.estimator.robust.eiv_noise_ratio, "(PSD ratio reference / test)");
  s.estimator.robust.estimate_delay = param_bool(p, "estimate_delay", s.estimator.robust.estimate_delay);
  s.estimator.robust.correct_delay = param_bool(p, "correct_delay", s.estimator.robust.correct_delay);
  if (s.estimator.robust.correct_delay && !s.estimator.robust.estimate_delay) {
    throw ParameterError("correct_delay", "is true but ~estimate_delay is false (nothing to correct)");
  }
  // Calibration change check against the accepted calibration.
  s.change.false_alarm_probability =
      param_double(p, "change_false_alarm_probability", s.change.false_alarm_probability);
  s.change.scale_tolerance = param_double(p, "change_scale_tolerance", s.change.scale_tolerance);
  s.change.angle_tolerance_deg = param_double(p, "change_angle_tolerance", s.change.angle_tolerance_deg);
  // A window must be able to hold min_harmonics harmonics j / window inside the band.
  const double harmonics = std::floor(s.estimator.band_high_hz * s.window_s) -
                           std::ceil(s.estimator.band_low_hz * s.window_s) + 1.0;
  if (harmonics < static_cast<double>(s.estimator.min_harmonics)) {
    throw ParameterError("window", "(" + text_of(s.window_s) + " s) holds only " + text_of(std::max(0.0, harmonics)) +
                                       " DFT harmonics in [~band_low, ~band_high], fewer than ~min_harmonics (" +
                                       std::to_string(s.estimator.min_harmonics) + "): every window would be flagged");
  }

  // Monitoring and queues.
  s.silent_timeout_s = param_double(p, "silent_timeout", s.silent_timeout_s);
  require_positive("silent_timeout", s.silent_timeout_s, "s");
  s.time_jump_threshold_s = param_double(p, "time_jump_threshold", s.time_jump_threshold_s);
  if (!(s.time_jump_threshold_s > s.input_period_s)) {
    throw ParameterError("time_jump_threshold", "must be longer than ~input_period (" + text_of(s.input_period_s) + " s)");
  }
  s.queue_size = param_int(p, "queue_size", s.queue_size);
  if (s.queue_size < 1) throw ParameterError("queue_size", "must be >= 1 message");
  s.max_pending_windows = param_int(p, "max_pending_windows", s.max_pending_windows);
  if (s.max_pending_windows < 1) throw ParameterError("max_pending_windows", "must be >= 1");
  s.diagnostic_period_s = param_double(p, "diagnostic_period", s.diagnostic_period_s);
  require_positive("diagnostic_period", s.diagnostic_period_s, "s");

  // The core's own checks, reported under the parameter's name.
  try {
    s.estimator.validate();
    s.change.validate();
    s.decimation.validate();
    WindowLayout{0, s.window_s, s.step_s}.validate();
  } catch (const InputError& e) {
    const auto it = kCoreFieldToParameter.find(e.where());
    throw ParameterError(it != kCoreFieldToParameter.end() ? it->second : e.where(), e.problem());
  }
  return s;
}

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
  for (const std::string& name : unknown_private_parameters(private_nh_, kKnownParameters)) {
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
             jump == StreamMonitor::Jump::kForward ? "forward" : "backward", iso(t).c_str());
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
             jump == StreamMonitor::Jump::kForward ? "forward" : "backward", iso(t).c_str());
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
    const std::string window = iso(m.window_start.toSec()) + " .. " + iso(m.window_end.toSec());
    ch.baseline = std::move(e);
    ch.baseline_window = window;
    ch.baseline_source = "file (loaded at start)";
    ch.last_accepted_window = window;
    ch.last_accepted_stamp = iso(m.header.stamp.toSec());
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
  const std::string window_text = iso(nominal_start) + " .. " + iso(nominal_end);
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
    ch.last_accepted_stamp = iso(m.header.stamp.toSec());
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
  status.add("newest stamp", reference_.messages > 0 ? iso(reference_.newest_stamp_s) : std::string("none"));
  status.add("stamp jumps forward", reference_.jumps_forward);
  status.add("stamp jumps backward", reference_.jumps_backward);
  status.add("stray stamps", reference_.stray);
  const double silence = reference_.silence_s(now, started_s_);
  status.add("silent for (s)", silence);
  if (started_s_ > 0.0 && silence > settings_.silent_timeout_s) {
    status.mergeSummary(DiagnosticStatus::WARN, reference_.messages > 0
                                                    ? "reference topic silent for " + text_of(std::round(silence)) + " s"
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
  status.add("test newest stamp", ch.test.messages > 0 ? iso(ch.test.newest_stamp_s) : std::string("none"));
  status.add("test stamp jumps forward", ch.test.jumps_forward);
  status.add("test stamp jumps backward", ch.test.jumps_backward);
  status.add("test stray stamps", ch.test.stray);
  const double silence = ch.test.silence_s(now, started_s_);
  status.add("test silent for (s)", silence);
  if (started_s_ > 0.0 && silence > settings_.silent_timeout_s) {
    problems.emplace_back(DiagnosticStatus::WARN, ch.test.messages > 0
                                                      ? "test topic silent for " + text_of(std::round(silence)) + " s"
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
