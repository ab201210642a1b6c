// The JSON report of a pair calibration (calibrate_records --json): see calibration_report.hpp.
#include "magnetometer_insitu_calibration/pipeline/calibration_report.hpp"

#include "magnetometer_insitu_calibration/pipeline/calibration_record.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_summary.hpp"
#include "magnetometer_insitu_calibration/estimation/window_agreement.hpp"
#include "json_number.hpp"

#include <cmath>

namespace magnetometer_insitu_calibration {
namespace {

using nlohmann::json;

using json_detail::number;

json vec3(const Eigen::Vector3d& v) { return json::array({number(v(0)), number(v(1)), number(v(2))}); }

template <typename Matrix>
json rows(const Matrix& m) {
  json out = json::array();
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    json row = json::array();
    for (Eigen::Index c = 0; c < m.cols(); ++c) row.push_back(number(m(r, c)));
    out.push_back(row);
  }
  return out;
}

}  // namespace

/// relative_response: one object per band, ci95 = 95 % half-widths as the other keys.
json response_to_json(const std::vector<ResponseBand>& bands) {
  json out = json::array();
  for (const auto& b : bands) {
    out.push_back(json{{"frequency_hz", number(b.frequency_hz)},
                       {"band_hz", json::array({number(b.low_hz), number(b.high_hz)})},
                       {"harmonics", b.harmonics},
                       {"gain", vec3(b.gain)},
                       {"gain_ci95", vec3(b.gain_ci95)},
                       {"phase_deg", vec3(b.phase_deg)},
                       {"phase_ci95_deg", vec3(b.phase_ci95_deg)}});
  }
  return out;
}

/// response_model: null when not fitted; corner_hz null per component without a significant corner.
json model_to_json(const ResponseModel& m) {
  if (!m.fitted) return json{{"fitted", false}, {"text", m.text}};
  json corners = json::array(), inverse = json::array(), inverse_ci = json::array();
  for (int k = 0; k < 3; ++k) {
    corners.push_back(m.inverse_corner_s(k) > 0.0 ? number(m.corner_hz(k)) : json(nullptr));
    inverse.push_back(number(m.inverse_corner_s(k)));
    inverse_ci.push_back(number(m.inverse_corner_ci95_s(k)));
  }
  return json{{"fitted", true}, {"applied", m.applied}, {"delay_s", number(m.delay_s)},
              {"delay_ci95_s", number(m.delay_ci95_s)}, {"corner_hz", corners},
              {"inverse_corner_s", inverse}, {"inverse_corner_ci95_s", inverse_ci},
              {"fit_max_hz", number(m.fit_max_hz)}, {"chi2_per_dof", number(m.chi2_per_dof)}, {"text", m.text}};
}

/// The scalar check (scalar_check.hpp); null when the window had no scalar record.
json scalar_to_json(const ScalarCheck& s) {
  if (s.text.empty()) return nullptr;
  return json{{"assessed", s.assessed},
              {"text", s.text},
              {"coefficients", vec3(s.coefficients)},
              {"coefficients_cells", number(s.cells)},
              {"reference_scale_along_field", number(s.reference_scale)},
              {"reference_scale_along_field_ci95", number(s.reference_scale_ci95)},
              {"direction_cosines", vec3(s.direction_cosines)},
              {"direction_cosines_ci95", vec3(s.direction_cosines_ci95)},
              {"axis_scale", vec3(s.axis_scale)},
              {"axis_scale_ci95", vec3(s.axis_scale_ci95)},
              {"direction_offset_deg", number(s.direction_offset_deg)},
              {"direction_offset_ci95_deg", number(s.direction_offset_ci95_deg)},
              {"test_scale_along_field", number(s.test_scale)},
              {"test_scale_along_field_ci95", number(s.test_scale_ci95)},
              {"delay_s", number(s.delay_s)},
              {"reference_needs_calibration", s.reference_off}};
}

json window_to_json(const CalibrationWindow& w, const CalibrationSettings& settings) {
  const WindowEstimate& e = w.estimate;
  // The record's names and frames are the node's; the inputs are the document's settings.
  RecordContext context;
  context.sample_period_s = e.sample_period_s;
  context.estimator = settings.window.estimator;
  json out = record_to_json(make_calibration_record(w, context));
  // Beyond the calibration record: the window's label and how it was estimated.
  out["label"] = w.label;
  out["matrix_stderr"] = rows(e.n_stderr());
  out["screened_fraction"] = e.screened_fraction;
  out["downweighted_fraction"] = e.downweighted_fraction;
  out["eiv"] = e.eiv_text();
  out["eiv_applied"] = errors_in_variables_name(e.eiv);
  out["reference_noise_source"] = noise_source_name(e.eiv_noise.source);
  out["reference_noise"] = w.reference_noise.text.empty() ? json() : json(w.reference_noise.text);
  out["weights"] = e.weights;
  out["intervals"] = e.intervals;
  out["relative_response"] = response_to_json(w.relative_response);
  out["response_model"] = model_to_json(w.response_model);
  out["scalar"] = scalar_to_json(w.scalar);
  out["verdicts"] = verdicts_to_json(w.verdicts);
  out["interval_narrowing"] = narrowing_to_json(w.narrowing);
  return out;
}

json window_agreement_to_json(const std::vector<CalibrationWindow>& windows) {
  const std::vector<WindowEstimate> parts = disjoint_window_estimates(windows);
  if (parts.empty()) return json(nullptr);
  const WindowAgreement a = check_window_agreement(parts);
  json parameters = json::object();
  for (int k = 0; k < 9; ++k) {
    const ParameterAgreement& p = a.parameters[k];
    parameters[kParameters[static_cast<std::size_t>(k)].name] =
        a.assessed ? json{{"weighted_mean", number(p.weighted_mean)},
                          {"chi2", number(p.chi2)},
                          {"expected_chi2", number(p.expected_chi2)},
                          {"sqrt_chi2_per_dof", number(p.birge_ratio)},
                          {"p_value", number(p.p_value)}}
                   : json(nullptr);
  }
  return json{{"assessed", a.assessed},
              {"agree", a.assessed ? json(a.agree) : json(nullptr)},
              {"windows", a.windows},
              {"joint_chi2", a.assessed ? number(a.joint_chi2) : json(nullptr)},
              {"joint_dof", a.joint_dof},
              {"joint_expected_chi2", a.assessed ? number(a.joint_expected_chi2) : json(nullptr)},
              {"joint_p_value", a.assessed ? number(a.joint_p_value) : json(nullptr)},
              {"joint_tested", a.assessed ? json(a.joint_tested) : json(nullptr)},
              {"parameters", parameters},
              {"text", a.text}};
}

json calibration_to_json(const PairCalibration& c, const CalibrationSettings& settings, const ReportInputs& inputs) {
  const PreprocessReport& r = c.report;
  const WindowCalibrationSettings& s = settings.window;
  json windows = json::array();
  for (const auto& w : c.windows) windows.push_back(window_to_json(w, settings));
  return json{
      {"settings",
       {{"reference", inputs.reference},
        {"test", inputs.test},
        {"reference_files", inputs.reference_files.empty() ? json() : json(inputs.reference_files)},
        {"test_files", inputs.test_files.empty() ? json() : json(inputs.test_files)},
        {"remote", inputs.remote.empty() ? json() : json(inputs.remote)},
        {"model", "T = R n + trend, rows are samples (nT); column l of n is test axis l in reference coordinates"},
        {"band_hz", json::array({s.estimator.band_low_hz, s.estimator.band_high_hz})},
        {"gamma", s.estimator.gamma},
        {"method", estimator_method_name(s.estimator.method)},
        {"auto_band", s.estimator.robust.auto_band},
        {"eiv", s.estimator.robust.errors_in_variables ? "given" : "none"},
        {"reference_noise_pT_per_sqrt_hz", 1e3 * s.reference_noise_figure.pink_nT_per_sqrt_hz.maxCoeff()},
        {"reference_noise_white_pT", 1e3 * s.reference_noise_figure.white_nT.maxCoeff()},
        {"pair_noise", s.pair_noise},
        {"three_cornered_hat", s.three_cornered_hat},
        {"response_model", s.response_model},
        {"trend", s.estimator.trend},
        {"intervals", settings.windows.intervals},
        {"window_s", settings.windows.window_s},
        {"step_s", settings.windows.step_s},
        {"pairing_tolerance_s", settings.preprocess.pairing_tolerance_s},
        {"output_period_s", settings.preprocess.output_period_s},
        {"despike", settings.preprocess.despike},
        {"max_fill_s", s.gaps.max_fill_s},
        {"temperature_channel", settings.preprocess.temperature_channel},
        {"max_filled_fraction", s.max_filled_fraction},
        {"min_harmonics", s.estimator.min_harmonics},
        {"max_condition_number", s.estimator.max_condition_number},
        {"min_coherence", s.estimator.min_coherence},
        {"tolerances", tolerances_to_json(s.tolerances)}}},
      {"preprocessing",
       {{"reference_samples", r.reference_samples},
        {"test_samples", r.test_samples},
        {"reference_period_s", r.reference_period_s},
        {"test_period_s", r.test_period_s},
        {"spikes_reference", r.spikes_reference},
        {"spikes_test", r.spikes_test},
        {"paired", r.paired},
        {"unpaired_reference", r.unpaired_reference},
        {"unpaired_test", r.unpaired_test},
        {"duplicates", r.duplicates},
        {"decimated", r.decimated()},
        {"epoch_alignment", epoch_alignment_name(r.alignment)},
        {"stamp_offset_s", r.stamp_offset_s},
        {"grid_samples", r.grid_samples},
        {"missing_samples", r.missing_samples},
        {"long_gaps", r.long_gaps},
        {"temperature_channel", r.temperature_channel.empty() ? json(nullptr) : json(r.temperature_channel)},
        {"reference_components", inputs.components_named ? json(r.reference_components) : json(nullptr)},
        {"test_components", inputs.components_named ? json(r.test_components) : json(nullptr)},
        {"reference_frame_id", inputs.reference_frame_id.empty() ? json(nullptr) : json(inputs.reference_frame_id)},
        {"test_frame_id", inputs.test_frame_id.empty() ? json(nullptr) : json(inputs.test_frame_id)}}},
      {"windows", windows},
      {"window_agreement", window_agreement_to_json(c.windows)},
  };
}

}  // namespace magnetometer_insitu_calibration
