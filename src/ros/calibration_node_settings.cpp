// Parameters of calibration_node: read and validated once at start-up (calibration_node.hpp,
// config/calibration.yaml). Every error names the parameter; nothing falls back silently.
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"

#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/tolerance_file.hpp"
#include "magnetometer_insitu_calibration/estimation/scalar_check.hpp"
#include "magnetometer_insitu_calibration/ros/parameters.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

namespace magnetometer_insitu_calibration {

namespace {

// Every private parameter of the node (others draw a start-up warning).
const std::vector<std::string> kCalibrationNodeParameters = {
    "reference_topic", "test_topic", "test_name", "calibration_topic", "calibration_file", "tests",
    "input_period", "output_period", "decimation_sigma", "decimation_half_width", "pairing_tolerance",
    "pairing_max_wait", "window", "step", "max_filled_fraction", "max_fill", "band_low", "band_high",
    "gamma", "trend", "min_harmonics", "max_condition_number", "min_coherence", "silent_timeout",
    "time_jump_threshold", "queue_size", "max_pending_windows", "diagnostic_period", "method", "auto_band", "eiv",
    "reference_noise_pT", "estimate_delay", "correct_delay", "change_false_alarm_probability",
    "change_scale_tolerance", "change_angle_tolerance", "publish_tf", "tf_child_frame_suffix", "temperature_topic",
    "temperature_min_range", "temperature_max_gap", "response_model", "three_cornered_hat", "pair_noise", "despike",
    "screen", "screen_threshold", "screen_baseline", "screen_margin", "section_length", "section_trend", "huber_k",
    "section_rejection", "iterations", "remote_topic", "scalar_topic", "field_direction", "tolerance_file",
    "test_input_period", "remote_input_period", "stamps_apart"};

// Core field names (InputError::where) -> the parameter that sets them.
const std::map<std::string, std::string> kCoreFieldToParameter = {
    {"band_low_hz", "band_low"}, {"band_high_hz", "band_high"}, {"gamma", "gamma"},
    {"min_harmonics", "min_harmonics"}, {"max_condition_number", "max_condition_number"},
    {"min_coherence", "min_coherence"}, {"output_period_s", "output_period"}, {"sigma_s", "decimation_sigma"},
    {"half_width_sigmas", "decimation_half_width"}, {"input_period_s", "input_period"},
    {"test_input_period_s", "test_input_period"}, {"remote_input_period_s", "remote_input_period"},
    {"tolerance_s", "pairing_tolerance"}, {"max_wait_s", "pairing_max_wait"}, {"window", "window"},
    {"step", "step"}, {"max_fill_s", "max_fill"}, {"max_fill", "max_fill"}, {"max_filled_fraction", "max_filled_fraction"},
    {"screen_baseline_s", "screen_baseline"}, {"screen_margin_s", "screen_margin"}, {"section_s", "section_length"},
    {"false_alarm_probability", "change_false_alarm_probability"},
    {"scale_tolerance", "change_scale_tolerance"}, {"angle_tolerance_deg", "change_angle_tolerance"}};

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

// An optional topic of a ~tests entry: absent or "" = none.
std::string optional_topic(XmlRpc::XmlRpcValue& entry, const std::string& key, const std::string& where) {
  if (!entry.hasMember(key)) return "";
  if (entry[key].getType() != XmlRpc::XmlRpcValue::TypeString) throw ParameterError(where + "." + key, "must be a string");
  const std::string value = static_cast<std::string>(entry[key]);
  if (!value.empty()) require_topic_name(where + "." + key, value);
  return value;
}

void load_streams(const ros::NodeHandle& p, CalibrationNodeSettings& s);
void load_estimator(const ros::NodeHandle& p, CalibrationNodeSettings& s);
void load_monitoring(const ros::NodeHandle& p, CalibrationNodeSettings& s);

}  // namespace

const std::vector<std::string>& CalibrationNodeSettings::known_parameters() { return kCalibrationNodeParameters; }

std::string CalibrationNodeSettings::noise_model_state() const {
  if (window.estimator.method != EstimatorMethod::kRobust) return "none (~method plain: Eq. 2 as printed)";
  if (!window.estimator.robust.errors_in_variables) return "off (~eiv none)";
  if (window.reference_noise_figure.any())
    return "the reference's noise figure, " + number_text(1e3 * window.reference_noise_figure.pink_nT_per_sqrt_hz.maxCoeff()) +
           " pT/sqrt(Hz) at 1 Hz (~reference_noise_pT)";
  std::string text;
  if (hat_active()) text = "identified in every window by the three-cornered hat with another test instrument";
  if (window.pair_noise) {
    text += text.empty() ? "identified in every window from the pair above the band"
                         : "; from the pair above the band where the hat identifies none";
  }
  if (text.empty()) text = "none: no figure, ~pair_noise false" + std::string(tests.size() >= 2 ? " and ~three_cornered_hat false" : "");
  return text;
}

CalibrationNodeSettings CalibrationNodeSettings::load(const ros::NodeHandle& p) {
  CalibrationNodeSettings s;
  s.reference_topic = required_string(p, "reference_topic");
  require_topic_name("reference_topic", s.reference_topic);

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
    t.temperature_topic = param_string(p, "temperature_topic", "");
    if (!t.temperature_topic.empty()) require_topic_name("temperature_topic", t.temperature_topic);
    require_topic_name("test_topic", t.topic);
    require_topic_name("calibration_topic", t.calibration_topic);
    s.tests.push_back(t);
  } else {
    for (const char* single_only : {"test_name", "calibration_topic", "calibration_file", "temperature_topic"}) {
      if (p.hasParam(single_only)) {
        throw ParameterError(single_only, "belongs to the single-instrument form (~test_topic); with ~tests give it per entry");
      }
    }
    XmlRpc::XmlRpcValue list;
    p.getParam("tests", list);
    if (list.getType() != XmlRpc::XmlRpcValue::TypeArray || list.size() == 0) {
      throw ParameterError("tests", "must be a non-empty list of {name, topic, calibration_file, calibration_topic (optional), "
                                    "temperature_topic (optional), input_period (optional)}");
    }
    for (int i = 0; i < list.size(); ++i) {
      const std::string where = "tests[" + std::to_string(i) + "]";
      XmlRpc::XmlRpcValue& entry = list[i];
      if (entry.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
        throw ParameterError(where, "must be a map {name, topic, calibration_file, calibration_topic (optional), "
                                    "temperature_topic (optional), input_period (optional)}");
      }
      for (const auto& member : entry) {
        if (member.first != "name" && member.first != "topic" && member.first != "calibration_topic" &&
            member.first != "calibration_file" && member.first != "temperature_topic" && member.first != "input_period") {
          throw ParameterError(where + "." + member.first, "unknown key (name, topic, calibration_topic, calibration_file, "
                                                           "temperature_topic, input_period)");
        }
      }
      TestInstrumentSettings t;
      t.name = struct_string(entry, "name", where, true, "");
      t.topic = struct_string(entry, "topic", where, true, "");
      t.calibration_topic = struct_string(entry, "calibration_topic", where, false, t.name + "/calibration");
      t.calibration_file = struct_string(entry, "calibration_file", where, true, "");
      t.temperature_topic = optional_topic(entry, "temperature_topic", where);
      if (entry.hasMember("input_period")) {  // this test's own period (checked with the streams below)
        XmlRpc::XmlRpcValue& v = entry["input_period"];
        if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) t.input_period_s = static_cast<double>(v);
        else if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) t.input_period_s = static_cast<int>(v);
        else throw ParameterError(where + ".input_period", "must be a number (s)");
        if (!(t.input_period_s > 0.0) || !std::isfinite(t.input_period_s)) {
          throw ParameterError(where + ".input_period", "must be > 0 s");
        }
      }
      require_topic_name(where + ".topic", t.topic);
      require_topic_name(where + ".calibration_topic", t.calibration_topic);
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
  // A thermometer topic (sensor_msgs/Temperature) is never one of the field or calibration
  // topics; two instruments may share one (a hut thermometer).
  for (std::size_t i = 0; i < s.tests.size(); ++i) {
    const std::string& topic = s.tests[i].temperature_topic;
    if (!topic.empty() && (topics.count(topic) != 0 || outputs.count(topic) != 0)) {
      throw ParameterError((has_list ? "tests[" + std::to_string(i) + "]." : std::string()) + "temperature_topic",
                           "'" + topic + "' is a magnetic field or calibration topic");
    }
  }

  // A remote observatory (any frame) and a scalar magnetometer: never one of the pair's or the
  // calibrations' topics, nor each other's.
  s.remote_topic = param_string(p, "remote_topic", "");
  s.scalar_topic = param_string(p, "scalar_topic", "");
  for (const auto& [name, topic] : {std::make_pair("remote_topic", s.remote_topic), std::make_pair("scalar_topic", s.scalar_topic)}) {
    if (topic.empty()) continue;
    require_topic_name(name, topic);
    if (topics.count(topic) != 0 || outputs.count(topic) != 0 || (topic == s.remote_topic && topic == s.scalar_topic)) {
      throw ParameterError(name, "'" + topic + "' is the reference, a test, a calibration, the remote or the scalar topic");
    }
  }
  // The main field's direction (D,I from the observatory's absolute observations): the scalar
  // check then gives the reference's scale per axis.
  const std::string field_direction = param_string(p, "field_direction", "");
  if (!field_direction.empty()) {
    if (s.scalar_topic.empty()) throw ParameterError("field_direction", "is used with ~scalar_topic only");
    try {
      s.window.field_direction = parse_field_direction(field_direction);
    } catch (const std::invalid_argument& e) {
      throw ParameterError("field_direction", e.what());
    }
  }
  load_streams(p, s);
  load_estimator(p, s);
  load_monitoring(p, s);
  // The core's own checks, reported under the parameter's name.
  try {
    s.window.validate();
    s.change.validate();
    s.streams.validate(!s.remote_topic.empty());
    // Each test's own period, and the hat's tests filtered alike: the streams' own check.
    const std::vector<LiveTestInput> tests = s.live_tests();
    for (std::size_t i = 0; i < tests.size(); ++i) {
      try {
        s.streams.validate_test(tests, i, s.hat_active());
      } catch (const InputError& e) {
        throw ParameterError("tests[" + std::to_string(i) + "].input_period", e.problem());
      }
    }
    WindowLayout{0, s.streams.window_s, s.streams.step_s}.validate();
  } catch (const InputError& e) {
    const auto it = kCoreFieldToParameter.find(e.where());
    throw ParameterError(it != kCoreFieldToParameter.end() ? it->second : e.where(), e.problem());
  }
  return s;
}

namespace {

/// Periods and decimation, pairing, windows and despiking (LiveStreamSettings), and the gap rule.
void load_streams(const ros::NodeHandle& p, CalibrationNodeSettings& s) {
  LiveStreamSettings& l = s.streams;
  l.input_period_s = param_double(p, "input_period", l.input_period_s);
  require_positive("input_period", l.input_period_s, "s");
  // Streams of other rates than the reference's, or stamped at another phase: each low-passed
  // onto the estimation epochs before pairing (plan_epochs, as calibrate_records does).
  l.test_input_period_s = param_double(p, "test_input_period", l.input_period_s);
  require_positive("test_input_period", l.test_input_period_s, "s");
  if (p.hasParam("remote_input_period") && s.remote_topic.empty()) {
    throw ParameterError("remote_input_period", "is used with ~remote_topic only");
  }
  l.remote_input_period_s = param_double(p, "remote_input_period", l.input_period_s);
  require_positive("remote_input_period", l.remote_input_period_s, "s");
  l.stamps_apart = param_bool(p, "stamps_apart", l.stamps_apart);
  l.decimation.output_period_s = param_double(p, "output_period", l.decimation.output_period_s);
  require_positive("output_period", l.decimation.output_period_s, "s");
  l.decimation.sigma_s = param_double(p, "decimation_sigma", l.decimation.sigma_s);
  require_non_negative("decimation_sigma", l.decimation.sigma_s, "s (0 = default)");
  l.decimation.half_width_sigmas = param_double(p, "decimation_half_width", l.decimation.half_width_sigmas);
  require_positive("decimation_half_width", l.decimation.half_width_sigmas, "sigmas");
  const double period = l.estimation_period_s();
  l.pairing_tolerance_s = param_double(p, "pairing_tolerance", l.pairing_tolerance_s);
  require_non_negative("pairing_tolerance", l.pairing_tolerance_s, "s");
  if (!(l.pairing_tolerance_s < 0.5 * l.input_period_s)) {
    throw ParameterError("pairing_tolerance", "must be below half of ~input_period (" + number_text(0.5 * l.input_period_s) +
                                                  " s): a sample could pair with its partner's neighbour");
  }
  l.pairing_max_wait_s = param_double(p, "pairing_max_wait", l.pairing_max_wait_s);
  require_non_negative("pairing_max_wait", l.pairing_max_wait_s, "s");
  l.window_s = param_double(p, "window", l.window_s);
  require_positive("window", l.window_s, "s");
  l.step_s = param_double(p, "step", l.step_s);
  require_positive("step", l.step_s, "s");
  if (l.step_s > l.window_s) {
    throw ParameterError("step", "(" + number_text(l.step_s) + " s) is longer than ~window (" + number_text(l.window_s) +
                                     " s): samples between windows would never be used");
  }
  if (l.step_s < period) throw ParameterError("step", "must be at least one sample period (" + number_text(period) + " s)");
  // Spikes removed from each stream at its own rate, as calibrate_records removes them.
  l.despike = param_bool(p, "despike", l.despike);
  WindowCalibrationSettings& w = s.window;
  w.max_filled_fraction = param_double(p, "max_filled_fraction", w.max_filled_fraction);
  require_in_range("max_filled_fraction", w.max_filled_fraction, 0.0, 1.0);
  w.gaps.max_fill_s = param_double(p, "max_fill", w.gaps.max_fill_s);
  require_non_negative("max_fill", w.gaps.max_fill_s, "s");
  // Temperature terms (when an instrument has a temperature topic). Default max gap: the
  // core's (60 s), at least two estimation periods.
  w.temperature.min_range_C = param_double(p, "temperature_min_range", w.temperature.min_range_C);
  require_non_negative("temperature_min_range", w.temperature.min_range_C, "degC");
  w.temperature_max_gap_s = param_double(p, "temperature_max_gap", std::max(w.temperature_max_gap_s, 2.0 * period));
  require_positive("temperature_max_gap", w.temperature_max_gap_s, "s");
  l.temperature_margin_s = w.temperature_max_gap_s;
}

/// The estimator, its reference noise, response model and robust options (WindowCalibrationSettings).
void load_estimator(const ros::NodeHandle& p, CalibrationNodeSettings& s) {
  EstimatorSettings& e = s.window.estimator;
  const double period = s.streams.estimation_period_s();
  e.band_low_hz = param_double(p, "band_low", e.band_low_hz);
  require_positive("band_low", e.band_low_hz, "Hz");
  e.band_high_hz = param_double(p, "band_high", e.band_high_hz);
  if (!(e.band_high_hz > e.band_low_hz)) {
    throw ParameterError("band_high", "(" + number_text(e.band_high_hz) + " Hz) must be above ~band_low (" +
                                          number_text(e.band_low_hz) + " Hz): the band is empty");
  }
  const std::string above_nyquist = e.band_above_nyquist(period);
  if (!above_nyquist.empty()) throw ParameterError("band_high", above_nyquist);
  e.gamma = param_double(p, "gamma", e.gamma);
  e.trend = param_bool(p, "trend", e.trend);
  const int min_harmonics = param_int(p, "min_harmonics", static_cast<int>(e.min_harmonics));
  if (min_harmonics < 1) throw ParameterError("min_harmonics", "must be >= 1");
  e.min_harmonics = static_cast<std::size_t>(min_harmonics);
  e.max_condition_number = param_double(p, "max_condition_number", e.max_condition_number);
  e.min_coherence = param_double(p, "min_coherence", e.min_coherence);
  const std::string eiv = param_string(p, "eiv", "given");
  if (eiv != "given" && eiv != "none") throw ParameterError("eiv", "expected given or none, got '" + eiv + "'");
  e.robust.errors_in_variables = eiv == "given";
  try {
    e.method = parse_estimator_method(param_string(p, "method", "robust"), "method");
  } catch (const InputError& error) {
    throw ParameterError(error.where(), error.problem());
  }
  // The reference's noise figure, pT/sqrt(Hz) at 1 Hz (1/f below); 0: identified from the data.
  const double figure_pT = param_double(p, "reference_noise_pT", 0.0);
  require_non_negative("reference_noise_pT", figure_pT, "(pT/sqrt(Hz) at 1 Hz)");
  s.window.reference_noise_figure = NoiseSpectrum::fluxgate_figure(figure_pT);
  s.window.three_cornered_hat = param_bool(p, "three_cornered_hat", s.window.three_cornered_hat);
  s.window.pair_noise = param_bool(p, "pair_noise", s.window.pair_noise);
  s.window.response_model = param_bool(p, "response_model", s.window.response_model);
  RobustSettings& r = e.robust;
  r.auto_band = param_bool(p, "auto_band", r.auto_band);
  r.estimate_delay = param_bool(p, "estimate_delay", r.estimate_delay);
  r.correct_delay = param_bool(p, "correct_delay", r.correct_delay);
  if (r.correct_delay && !r.estimate_delay) {
    throw ParameterError("correct_delay", "is true but ~estimate_delay is false (nothing to correct)");
  }
  // The robust estimator's own steps (robust_estimator.hpp; docs/method.md).
  r.screen = param_bool(p, "screen", r.screen);
  r.screen_threshold = param_double(p, "screen_threshold", r.screen_threshold);
  r.screen_baseline_s = param_double(p, "screen_baseline", r.screen_baseline_s);
  r.screen_margin_s = param_double(p, "screen_margin", r.screen_margin_s);
  r.section_s = param_double(p, "section_length", r.section_s);
  r.section_trend = param_bool(p, "section_trend", r.section_trend);
  r.huber_k = param_double(p, "huber_k", r.huber_k);
  r.section_rejection = param_double(p, "section_rejection", r.section_rejection);
  r.iterations = param_int(p, "iterations", r.iterations);
  // A window must be able to hold min_harmonics harmonics j / window inside the band: the rule
  // calibrate_records applies to --window and --intervals, in its words.
  const std::string too_short = e.too_few_harmonics(s.streams.window_s);
  if (!too_short.empty()) throw ParameterError("window", "(" + number_text(s.streams.window_s) + " s) " + too_short);
}

/// The change check, monitoring, queues and TF.
void load_monitoring(const ros::NodeHandle& p, CalibrationNodeSettings& s) {
  s.change.false_alarm_probability = param_double(p, "change_false_alarm_probability", s.change.false_alarm_probability);
  s.change.scale_tolerance = param_double(p, "change_scale_tolerance", s.change.scale_tolerance);
  s.change.angle_tolerance_deg = param_double(p, "change_angle_tolerance", s.change.angle_tolerance_deg);
  const std::string tolerance_file = param_string(p, "tolerance_file", "");
  try {
    if (!tolerance_file.empty()) s.window.tolerances = read_tolerance_file(tolerance_file);
  } catch (const InputError& e) {
    throw ParameterError("tolerance_file", e.what());
  }
  s.silent_timeout_s = param_double(p, "silent_timeout", s.silent_timeout_s);
  require_positive("silent_timeout", s.silent_timeout_s, "s");
  s.time_jump_threshold_s = param_double(p, "time_jump_threshold", s.time_jump_threshold_s);
  double slowest = std::max({s.streams.input_period_s, s.streams.test_period_s(), s.streams.remote_period_s()});
  for (const TestInstrumentSettings& t : s.tests) slowest = std::max(slowest, t.input_period_s);
  if (!(s.time_jump_threshold_s > slowest)) {
    throw ParameterError("time_jump_threshold",
                         "must be longer than the slowest stream's period (" + number_text(slowest) + " s)");
  }
  s.streams.time_jump_threshold_s = s.time_jump_threshold_s;
  s.queue_size = param_int(p, "queue_size", s.queue_size);
  if (s.queue_size < 1) throw ParameterError("queue_size", "must be >= 1 message");
  s.max_pending_windows = param_int(p, "max_pending_windows", s.max_pending_windows);
  if (s.max_pending_windows < 1) throw ParameterError("max_pending_windows", "must be >= 1");
  s.diagnostic_period_s = param_double(p, "diagnostic_period", s.diagnostic_period_s);
  require_positive("diagnostic_period", s.diagnostic_period_s, "s");
  // TF: the rotation part of accepted calibrations on /tf_static (calibration_node_tf.cpp).
  s.publish_tf = param_bool(p, "publish_tf", s.publish_tf);
  s.tf_child_frame_suffix = param_string(p, "tf_child_frame_suffix", s.tf_child_frame_suffix);
  if (s.tf_child_frame_suffix.find_first_of(" \t/") != std::string::npos) {
    throw ParameterError("tf_child_frame_suffix", "'" + s.tf_child_frame_suffix + "' must not contain spaces or '/'");
  }
}

}  // namespace

}  // namespace magnetometer_insitu_calibration
