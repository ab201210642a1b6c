// Parameters of calibration_node: read and validated once at start-up (calibration_node.hpp,
// config/calibration.yaml). Every error names the parameter; nothing falls back silently.
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"

#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/ros/parameters.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

namespace magnetometer_insitu_calibration {

namespace {

// Every private parameter of the node (others draw a start-up warning).
const std::vector<std::string> kKnownParameters = {
    "reference_topic", "test_topic", "test_name", "calibration_topic", "calibration_file", "tests",
    "input_period", "output_period", "decimation_sigma", "decimation_half_width", "pairing_tolerance",
    "pairing_max_wait", "window", "step", "max_filled_fraction", "max_fill", "band_low", "band_high",
    "gamma", "trend", "min_harmonics", "max_condition_number", "min_coherence", "silent_timeout",
    "time_jump_threshold", "queue_size", "max_pending_windows", "diagnostic_period", "method", "auto_band", "eiv",
    "eiv_noise_ratio", "reference_noise_pT", "estimate_delay", "correct_delay", "change_false_alarm_probability",
    "change_scale_tolerance", "change_angle_tolerance", "publish_tf", "tf_child_frame_suffix", "temperature_topic",
    "temperature_min_range", "temperature_max_gap", "response_model", "three_cornered_hat", "pair_noise", "despike"};

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

}  // namespace

const std::vector<std::string>& CalibrationNodeSettings::known_parameters() { return kKnownParameters; }

std::string CalibrationNodeSettings::hat_state() const {
  if (hat_active()) return "on: the reference's noise from the reference and two tests, every window";
  if (!three_cornered_hat) return "off (~three_cornered_hat false)";
  if (tests.size() < 2) return "off (one test instrument: a third is needed)";
  if (estimator.method != EstimatorMethod::kRobust) return "off (~method plain)";
  if (estimator.robust.eiv != EivCorrection::kGiven) return "off (~eiv is not given)";
  return "off (~reference_noise_pT given: the maker's figure is used)";
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
                                    "temperature_topic (optional)}");
    }
    for (int i = 0; i < list.size(); ++i) {
      const std::string where = "tests[" + std::to_string(i) + "]";
      XmlRpc::XmlRpcValue& entry = list[i];
      if (entry.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
        throw ParameterError(where, "must be a map {name, topic, calibration_file, calibration_topic (optional), "
                                    "temperature_topic (optional)}");
      }
      for (const auto& member : entry) {
        if (member.first != "name" && member.first != "topic" && member.first != "calibration_topic" &&
            member.first != "calibration_file" && member.first != "temperature_topic") {
          throw ParameterError(where + "." + member.first,
                               "unknown key (name, topic, calibration_topic, calibration_file, temperature_topic)");
        }
      }
      TestInstrumentSettings t;
      t.name = struct_string(entry, "name", where, true, "");
      t.topic = struct_string(entry, "topic", where, true, "");
      t.calibration_topic = struct_string(entry, "calibration_topic", where, false, t.name + "/calibration");
      t.calibration_file = struct_string(entry, "calibration_file", where, true, "");
      t.temperature_topic = optional_topic(entry, "temperature_topic", where);
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
    throw ParameterError("pairing_tolerance", "must be below half of ~input_period (" + number_text(0.5 * s.input_period_s) +
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
    throw ParameterError("step", "(" + number_text(s.step_s) + " s) is longer than ~window (" + number_text(s.window_s) +
                                     " s): samples between windows would never be used");
  }
  if (s.step_s < period) throw ParameterError("step", "must be at least one sample period (" + number_text(period) + " s)");
  s.gap_rule.max_filled_fraction = param_double(p, "max_filled_fraction", s.gap_rule.max_filled_fraction);
  require_in_range("max_filled_fraction", s.gap_rule.max_filled_fraction, 0.0, 1.0);
  s.gap_rule.gaps.max_fill_s = param_double(p, "max_fill", s.gap_rule.gaps.max_fill_s);
  require_non_negative("max_fill", s.gap_rule.gaps.max_fill_s, "s");

  // Estimator.
  s.estimator.band_low_hz = param_double(p, "band_low", s.estimator.band_low_hz);
  require_positive("band_low", s.estimator.band_low_hz, "Hz");
  s.estimator.band_high_hz = param_double(p, "band_high", s.estimator.band_high_hz);
  if (!(s.estimator.band_high_hz > s.estimator.band_low_hz)) {
    throw ParameterError("band_high", "(" + number_text(s.estimator.band_high_hz) + " Hz) must be above ~band_low (" +
                                          number_text(s.estimator.band_low_hz) + " Hz): the band is empty");
  }
  if (s.estimator.band_high_hz > 0.5 / period) {
    throw ParameterError("band_high", "(" + number_text(s.estimator.band_high_hz) + " Hz) is above the Nyquist frequency " +
                                          number_text(0.5 / period) + " Hz of the " + number_text(period) + " s estimation period");
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
    s.estimator.robust.eiv = parse_eiv_correction(param_string(p, "eiv", "given"), "eiv");
  } catch (const InputError& e) {
    throw ParameterError(e.where(), e.problem());
  }
  // ~reference_noise_pT: the reference's noise figure, pT/sqrt(Hz) at 1 Hz (1/f below); 0 (the
  // default): not identified, no errors-in-variables correction (eiv given).
  const double reference_noise_pT = param_double(p, "reference_noise_pT", 0.0);
  require_non_negative("reference_noise_pT", reference_noise_pT, "(pT/sqrt(Hz) at 1 Hz)");
  s.estimator.robust.reference_pink_nT_per_sqrt_hz.setConstant(reference_noise_pT / 1000.0);
  s.estimator.robust.auto_band = param_bool(p, "auto_band", s.estimator.robust.auto_band);
  s.estimator.robust.eiv_noise_ratio = param_double(p, "eiv_noise_ratio", s.estimator.robust.eiv_noise_ratio);
  require_non_negative("eiv_noise_ratio", s.estimator.robust.eiv_noise_ratio, "(PSD ratio reference / test)");
  s.estimator.robust.estimate_delay = param_bool(p, "estimate_delay", s.estimator.robust.estimate_delay);
  s.estimator.robust.correct_delay = param_bool(p, "correct_delay", s.estimator.robust.correct_delay);
  if (s.estimator.robust.correct_delay && !s.estimator.robust.estimate_delay) {
    throw ParameterError("correct_delay", "is true but ~estimate_delay is false (nothing to correct)");
  }
  // ~three_cornered_hat: with two or more test instruments, the reference's noise identified in
  // every window from the reference and two tests (live_three_cornered_hat.hpp; hat_active()).
  s.three_cornered_hat = param_bool(p, "three_cornered_hat", s.three_cornered_hat);
  // ~pair_noise: where the hat is not used, the reference's noise from each window's pair above
  // the band (reference_noise.hpp, identify_reference_noise_from_pair; pair_noise_active()).
  s.pair_noise = param_bool(p, "pair_noise", s.pair_noise);
  // Calibration change check against the accepted calibration.
  s.change.false_alarm_probability =
      param_double(p, "change_false_alarm_probability", s.change.false_alarm_probability);
  s.change.scale_tolerance = param_double(p, "change_scale_tolerance", s.change.scale_tolerance);
  s.change.angle_tolerance_deg = param_double(p, "change_angle_tolerance", s.change.angle_tolerance_deg);
  // A window must be able to hold min_harmonics harmonics j / window inside the band.
  const double harmonics = std::floor(s.estimator.band_high_hz * s.window_s) -
                           std::ceil(s.estimator.band_low_hz * s.window_s) + 1.0;
  if (harmonics < static_cast<double>(s.estimator.min_harmonics)) {
    throw ParameterError("window", "(" + number_text(s.window_s) + " s) holds only " + number_text(std::max(0.0, harmonics)) +
                                       " DFT harmonics in [~band_low, ~band_high], fewer than ~min_harmonics (" +
                                       std::to_string(s.estimator.min_harmonics) + "): every window would be flagged");
  }

  // Monitoring and queues.
  s.silent_timeout_s = param_double(p, "silent_timeout", s.silent_timeout_s);
  require_positive("silent_timeout", s.silent_timeout_s, "s");
  s.time_jump_threshold_s = param_double(p, "time_jump_threshold", s.time_jump_threshold_s);
  if (!(s.time_jump_threshold_s > s.input_period_s)) {
    throw ParameterError("time_jump_threshold", "must be longer than ~input_period (" + number_text(s.input_period_s) + " s)");
  }
  s.queue_size = param_int(p, "queue_size", s.queue_size);
  if (s.queue_size < 1) throw ParameterError("queue_size", "must be >= 1 message");
  s.max_pending_windows = param_int(p, "max_pending_windows", s.max_pending_windows);
  if (s.max_pending_windows < 1) throw ParameterError("max_pending_windows", "must be >= 1");
  s.diagnostic_period_s = param_double(p, "diagnostic_period", s.diagnostic_period_s);
  require_positive("diagnostic_period", s.diagnostic_period_s, "s");

  // Temperature terms (when an instrument has a temperature topic).
  s.gap_rule.temperature.min_range_C = param_double(p, "temperature_min_range", s.gap_rule.temperature.min_range_C);
  require_non_negative("temperature_min_range", s.gap_rule.temperature.min_range_C, "degC");
  // Default: the gap rule's longest filled gap, at least two estimation periods.
  s.gap_rule.temperature_max_gap_s =
      param_double(p, "temperature_max_gap", std::max(s.gap_rule.gaps.max_fill_s, 2.0 * period));
  require_positive("temperature_max_gap", s.gap_rule.temperature_max_gap_s, "s");

  // Spikes removed from each window before its gaps are filled, as offline.
  s.gap_rule.despike = param_bool(p, "despike", s.gap_rule.despike);
  // Response model: n estimated through a significant 1-pole corner of a test component.
  s.gap_rule.response_model = param_bool(p, "response_model", s.gap_rule.response_model);

  // TF: the rotation part of accepted calibrations on /tf_static (calibration_node_tf.cpp).
  s.publish_tf = param_bool(p, "publish_tf", s.publish_tf);
  s.tf_child_frame_suffix = param_string(p, "tf_child_frame_suffix", s.tf_child_frame_suffix);
  if (s.tf_child_frame_suffix.find_first_of(" \t/") != std::string::npos) {
    throw ParameterError("tf_child_frame_suffix", "'" + s.tf_child_frame_suffix + "' must not contain spaces or '/'");
  }

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

}  // namespace magnetometer_insitu_calibration
