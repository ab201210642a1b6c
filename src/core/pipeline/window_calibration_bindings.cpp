// The declared settings bound to the core's settings structs: the per-window stage's
// (WindowCalibrationSettings, shared by the node and calibrate_records) and calibrate_records'
// CalibrationSettings (setting_declarations.hpp).
#include "magnetometer_insitu_calibration/pipeline/setting_declarations.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/estimation/scalar_check.hpp"

#include <stdexcept>

namespace magnetometer_insitu_calibration {

namespace {

using W = WindowCalibrationSettings;

void bind_rules(SettingBindings<W>& b) {
  b.bind("max_filled_fraction", [](W& w) -> double& { return w.max_filled_fraction; })
      .bind("max_fill", [](W& w) -> double& { return w.gaps.max_fill_s; })
      .bind("temperature_min_range", [](W& w) -> double& { return w.temperature.min_range_C; })
      .bind("temperature_max_gap", [](W& w) -> double& { return w.temperature_max_gap_s; })
      .bind("band_low_hz", [](W& w) -> double& { return w.estimator.band_low_hz; })
      .bind("band_high_hz", [](W& w) -> double& { return w.estimator.band_high_hz; })
      .bind("gamma", [](W& w) -> double& { return w.estimator.gamma; })
      .bind("trend", [](W& w) -> bool& { return w.estimator.trend; })
      .bind("min_harmonics", [](W& w) -> std::size_t& { return w.estimator.min_harmonics; })
      .bind("max_condition_number", [](W& w) -> double& { return w.estimator.max_condition_number; })
      .bind("min_coherence", [](W& w) -> double& { return w.estimator.min_coherence; });
}

void bind_noise_and_models(SettingBindings<W>& b) {
  b.bind_with(
      "method", [](W& w, const SettingValue& v) { w.estimator.method = parse_estimator_method(std::get<std::string>(v), "method"); },
      [](const W& w) { return SettingValue(std::string(estimator_method_name(w.estimator.method))); });
  b.bind("auto_band", [](W& w) -> bool& { return w.estimator.robust.auto_band; });
  b.bind_with(
      "eiv", [](W& w, const SettingValue& v) { w.estimator.robust.errors_in_variables = std::get<std::string>(v) == "given"; },
      [](const W& w) { return SettingValue(std::string(w.estimator.robust.errors_in_variables ? "given" : "none")); });
  b.bind_with(
      "reference_noise_figure",
      [](W& w, const SettingValue& v) { w.reference_noise_figure = NoiseSpectrum::fluxgate_figure(std::get<double>(v)); },
      [](const W& w) { return SettingValue(1e3 * w.reference_noise_figure.pink_nT_per_sqrt_hz.maxCoeff()); });
  b.bind("three_cornered_hat", [](W& w) -> bool& { return w.three_cornered_hat; })
      .bind("pair_noise", [](W& w) -> bool& { return w.pair_noise; })
      .bind("estimate_delay", [](W& w) -> bool& { return w.estimator.robust.estimate_delay; })
      .bind("correct_delay", [](W& w) -> bool& { return w.estimator.robust.correct_delay; })
      .bind("response_model", [](W& w) -> bool& { return w.response_model; });
  b.bind_with(
      "field_direction",
      [](W& w, const SettingValue& v) {
        const std::string& text = std::get<std::string>(v);
        try {
          w.field_direction = text.empty() ? std::nullopt : std::optional<FieldDirection>(parse_field_direction(text));
        } catch (const std::invalid_argument& e) {
          throw InputError("field_direction", e.what());
        }
      },
      [](const W& w) { return SettingValue(std::string(w.field_direction ? "set" : "")); });
}

void bind_robust_steps(SettingBindings<W>& b) {
  b.bind("screen", [](W& w) -> bool& { return w.estimator.robust.screen; })
      .bind("screen_threshold", [](W& w) -> double& { return w.estimator.robust.screen_threshold; })
      .bind("screen_baseline_s", [](W& w) -> double& { return w.estimator.robust.screen_baseline_s; })
      .bind("screen_margin_s", [](W& w) -> double& { return w.estimator.robust.screen_margin_s; })
      .bind("section_s", [](W& w) -> double& { return w.estimator.robust.section_s; })
      .bind("section_trend", [](W& w) -> bool& { return w.estimator.robust.section_trend; })
      .bind("huber_k", [](W& w) -> double& { return w.estimator.robust.huber_k; })
      .bind("section_rejection", [](W& w) -> double& { return w.estimator.robust.section_rejection; })
      .bind("iterations", [](W& w) -> int& { return w.estimator.robust.iterations; });
}

}  // namespace

const SettingBindings<WindowCalibrationSettings>& window_calibration_bindings() {
  static const SettingBindings<W> bindings = [] {
    SettingBindings<W> b(calibration_setting_declarations());
    bind_rules(b);
    bind_noise_and_models(b);
    bind_robust_steps(b);
    return b;
  }();
  return bindings;
}

const SettingBindings<CalibrationSettings>& calibration_settings_bindings() {
  using S = CalibrationSettings;
  static const SettingBindings<S> bindings = [] {
    SettingBindings<S> b(calibration_setting_declarations());
    b.bind("pairing_tolerance_s", [](S& s) -> double& { return s.preprocess.pairing_tolerance_s; })
        .bind("output_period_s", [](S& s) -> double& { return s.preprocess.output_period_s; })
        .bind("despike", [](S& s) -> bool& { return s.preprocess.despike; })
        .bind("temperature_channel", [](S& s) -> std::string& { return s.preprocess.temperature_channel; })
        .bind("window", [](S& s) -> double& { return s.windows.window_s; })
        .bind("step", [](S& s) -> double& { return s.windows.step_s; })
        .bind("intervals", [](S& s) -> int& { return s.windows.intervals; });
    b.include(window_calibration_bindings(), [](S& s) -> W& { return s.window; });
    return b;
  }();
  return bindings;
}

}  // namespace magnetometer_insitu_calibration
