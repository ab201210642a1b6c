// Parameters of calibration_node: read and validated once at start-up. Each is declared once
// (pipeline/setting_declarations.hpp: name, unit, default, range, help; config/calibration.yaml
// and docs/nodes.md are printed from the declarations). Every error names the parameter;
// nothing falls back silently.
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"

#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/pipeline/setting_declarations.hpp"
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

using N = CalibrationNodeSettings;

}  // namespace

/// The declared settings the node reads into its settings (the topics, the ~tests list and the
/// tolerance file have their own code below).
const SettingBindings<N>& CalibrationNodeSettings::bindings() {
  static const SettingBindings<N> bindings = [] {
    SettingBindings<N> b(calibration_setting_declarations());
    b.include(window_calibration_bindings(), [](N& n) -> WindowCalibrationSettings& { return n.window; });
    b.bind("input_period_s", [](N& n) -> double& { return n.streams.input_period_s; })
        .bind("test_input_period_s", [](N& n) -> double& { return n.streams.test_input_period_s; })
        .bind("remote_input_period_s", [](N& n) -> double& { return n.streams.remote_input_period_s; })
        .bind("stamps_apart", [](N& n) -> bool& { return n.streams.stamps_apart; })
        .bind("output_period_s", [](N& n) -> double& { return n.streams.decimation.output_period_s; })
        .bind("sigma_s", [](N& n) -> double& { return n.streams.decimation.sigma_s; })
        .bind("half_width_sigmas", [](N& n) -> double& { return n.streams.decimation.half_width_sigmas; })
        .bind("pairing_tolerance_s", [](N& n) -> double& { return n.streams.pairing_tolerance_s; })
        .bind("pairing_max_wait_s", [](N& n) -> double& { return n.streams.pairing_max_wait_s; })
        .bind("remote_max_wait_s", [](N& n) -> double& { return n.streams.remote_max_wait_s; })
        .bind("window", [](N& n) -> double& { return n.streams.window_s; })
        .bind("step", [](N& n) -> double& { return n.streams.step_s; })
        .bind("despike", [](N& n) -> bool& { return n.streams.despike; })
        .bind("false_alarm_probability", [](N& n) -> double& { return n.change.false_alarm_probability; })
        .bind("scale_tolerance", [](N& n) -> double& { return n.change.scale_tolerance; })
        .bind("angle_tolerance_deg", [](N& n) -> double& { return n.change.angle_tolerance_deg; })
        .bind("silent_timeout", [](N& n) -> double& { return n.silent_timeout_s; })
        .bind("time_jump_threshold", [](N& n) -> double& { return n.time_jump_threshold_s; })
        .bind("queue_size", [](N& n) -> int& { return n.queue_size; })
        .bind("max_pending_windows", [](N& n) -> int& { return n.max_pending_windows; })
        .bind("diagnostic_period", [](N& n) -> double& { return n.diagnostic_period_s; })
        .bind("publish_tf", [](N& n) -> bool& { return n.publish_tf; })
        .bind("tf_child_frame_suffix", [](N& n) -> std::string& { return n.tf_child_frame_suffix; });
    return b;
  }();
  return bindings;
}

namespace {

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

void check_rules(const ros::NodeHandle& p, CalibrationNodeSettings& s);

}  // namespace

const std::vector<std::string>& CalibrationNodeSettings::known_parameters() {
  static const std::vector<std::string> names = declared_parameters(calibration_setting_declarations());
  return names;
}

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
  load_declared(p, bindings(), s);
  check_rules(p, s);
  const std::string tolerance_file = param_string(p, "tolerance_file", "");
  try {
    if (!tolerance_file.empty()) s.window.tolerances = read_tolerance_file(tolerance_file);
  } catch (const InputError& e) {
    throw ParameterError("tolerance_file", e.what());
  }
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
    throw parameter_error(e, calibration_setting_declarations());
  }
  return s;
}

namespace {

/// The rules between settings that the node alone has (the core's own run in load above).
void check_rules(const ros::NodeHandle& p, CalibrationNodeSettings& s) {
  LiveStreamSettings& l = s.streams;
  WindowCalibrationSettings& w = s.window;
  if (w.field_direction && s.scalar_topic.empty()) throw ParameterError("field_direction", "is used with ~scalar_topic only");
  if (p.hasParam("remote_input_period") && s.remote_topic.empty()) {
    throw ParameterError("remote_input_period", "is used with ~remote_topic only");
  }
  const double period = l.estimation_period_s();
  if (!(l.pairing_tolerance_s < 0.5 * l.input_period_s)) {
    throw ParameterError("pairing_tolerance", "must be below half of ~input_period (" + number_text(0.5 * l.input_period_s) +
                                                  " s): a sample could pair with its partner's neighbour");
  }
  if (l.step_s > l.window_s) {
    throw ParameterError("step", "(" + number_text(l.step_s) + " s) is longer than ~window (" + number_text(l.window_s) +
                                     " s): samples between windows would never be used");
  }
  if (l.step_s < period) throw ParameterError("step", "must be at least one sample period (" + number_text(period) + " s)");
  // The thermometer's gap rule: at least two estimation periods unless given.
  if (!p.hasParam("temperature_max_gap")) w.temperature_max_gap_s = std::max(w.temperature_max_gap_s, 2.0 * period);
  l.temperature_margin_s = w.temperature_max_gap_s;
  const EstimatorSettings& e = w.estimator;
  if (!(e.band_high_hz > e.band_low_hz)) {
    throw ParameterError("band_high", "(" + number_text(e.band_high_hz) + " Hz) must be above ~band_low (" +
                                          number_text(e.band_low_hz) + " Hz): the band is empty");
  }
  const std::string above_nyquist = e.band_above_nyquist(period);
  if (!above_nyquist.empty()) throw ParameterError("band_high", above_nyquist);
  if (e.robust.correct_delay && !e.robust.estimate_delay) {
    throw ParameterError("correct_delay", "is true but ~estimate_delay is false (nothing to correct)");
  }
  // A window must hold min_harmonics harmonics j / window inside the band: calibrate_records'
  // rule for --window and --intervals, in its words.
  const std::string too_short = e.too_few_harmonics(l.window_s);
  if (!too_short.empty()) throw ParameterError("window", "(" + number_text(l.window_s) + " s) " + too_short);
  double slowest = std::max({l.input_period_s, l.test_period_s(), l.remote_period_s()});
  for (const TestInstrumentSettings& t : s.tests) slowest = std::max(slowest, t.input_period_s);
  if (!(s.time_jump_threshold_s > slowest)) {
    throw ParameterError("time_jump_threshold",
                         "must be longer than the slowest stream's period (" + number_text(slowest) + " s)");
  }
  l.time_jump_threshold_s = s.time_jump_threshold_s;
  if (s.tf_child_frame_suffix.find_first_of(" \t/") != std::string::npos) {
    throw ParameterError("tf_child_frame_suffix", "'" + s.tf_child_frame_suffix + "' must not contain spaces or '/'");
  }
}

}  // namespace

}  // namespace magnetometer_insitu_calibration
