// JSON and table reports of a pair calibration.
#include "magnetometer_insitu_calibration/pipeline/calibration_report.hpp"

#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_record.hpp"
#include "magnetometer_insitu_calibration/estimation/window_agreement.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace magnetometer_insitu_calibration {
namespace {

using nlohmann::json;

json number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

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
        {"min_coherence", s.estimator.min_coherence}}},
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
        {"decimated", r.decimated},
        {"grid_samples", r.grid_samples},
        {"missing_samples", r.missing_samples},
        {"long_gaps", r.long_gaps},
        {"temperature_channel", r.temperature_channel.empty() ? json(nullptr) : json(r.temperature_channel)}}},
      {"windows", windows},
      {"window_agreement", window_agreement_to_json(c.windows)},
  };
}

namespace {

/// "value ± ci" with `decimals` decimals; "-" when the value is not finite.
std::string with_ci(double value, double ci, int decimals) {
  if (!std::isfinite(value)) return "-";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f ± %.*f", decimals, value, decimals, ci);
  return buffer;
}

const char* const kAxes[3] = {"x", "y", "z"};
const char* const kAxisPairs[3] = {"xy", "xz", "yz"};

/// The distinct texts of the windows, in the order first seen (usually one or two kinds).
template <typename Text>
std::vector<std::string> distinct_texts(const std::vector<CalibrationWindow>& windows, Text text) {
  std::vector<std::string> texts;
  for (const auto& w : windows) {
    const std::string t = text(w);
    if (std::find(texts.begin(), texts.end(), t) == texts.end()) texts.push_back(t);
  }
  return texts;
}

/// The head: inputs, model, pre-processing counts, then the errors-in-variables noise models
/// and the weights and intervals of the windows, and a blank line.
void write_header(std::ostream& out, const PairCalibration& c, const ReportInputs& inputs) {
  const PreprocessReport& r = c.report;
  out << "reference: " << inputs.reference << "\ntest:      " << inputs.test << "\n"
      << "model T = R n + trend; values ± half-width of the 95 % interval (n's parameters: Student's t with the "
         "cells n's covariance rests on)\n"
      << "pre-processing: " << r.paired << " pairs (" << r.unpaired_reference << " reference and "
      << r.unpaired_test << " test samples unpaired), spikes removed " << r.spikes_reference << " / "
      << r.spikes_test << (r.decimated ? ", Gaussian FIR decimated" : "") << ", " << r.grid_samples
      << " samples on the grid, " << r.missing_samples << " missing (filled in the windows), " << r.long_gaps
      << " long gaps\n";
  const std::vector<std::string> models =
      distinct_texts(c.windows, [](const CalibrationWindow& w) { return w.estimate.eiv_text(); });
  out << "EIV:";
  for (std::size_t k = 0; k < models.size(); ++k) out << (k ? "; " : " ") << models[k];
  const std::vector<std::string> kinds = distinct_texts(c.windows, [](const CalibrationWindow& w) {
    return w.estimate.weights + "; intervals: " + w.estimate.intervals;
  });
  out << "\nweights:";
  for (std::size_t k = 0; k < kinds.size(); ++k) out << (k ? " | " : " ") << kinds[k];
  out << "\n\n";
}

/// The table of few windows: one row per quantity, one column per window. The label takes 26
/// characters, each cell 24 (at least one space after it).
struct WindowColumns {
  std::ostream& out;
  const std::vector<CalibrationWindow>& windows;

  template <typename Cell>
  void row(const std::string& label, Cell cell) const {
    const int label_width = 26, column_width = 24;
    char head[64];
    std::snprintf(head, sizeof head, "%-*s", label_width, label.c_str());
    out << head;
    for (const auto& w : windows) {
      const std::string text = cell(w);
      // pad by characters, not bytes ("±" is two bytes in UTF-8)
      std::size_t chars = 0;
      for (unsigned char ch : text) chars += (ch & 0xC0) != 0x80;
      out << text << std::string(chars < column_width ? column_width - chars : 1, ' ');
    }
    out << "\n";
  }
};

/// Rows of what each window is and how it was estimated: label, span, samples, method, band
/// (Hz), harmonics, the covariance's cells and the interval quantile, the delay (s).
void write_estimation_rows(const WindowColumns& table) {
  table.row("", [](const CalibrationWindow& w) { return w.label; });
  table.row("start (UTC)", [](const CalibrationWindow& w) { return format_iso8601(w.start_s, 0); });
  table.row("end (UTC)", [](const CalibrationWindow& w) { return format_iso8601(w.end_s, 0); });
  table.row("samples", [](const CalibrationWindow& w) { return std::to_string(w.estimate.samples); });
  table.row("method", [](const CalibrationWindow& w) { return w.estimate.method; });
  table.row("band used Hz", [](const CalibrationWindow& w) {
    char b[64];
    std::snprintf(b, sizeof b, "%.4g-%.4g", w.estimate.band_low_hz, w.estimate.band_high_hz);
    return std::string(b);
  });
  table.row("harmonics m0..m", [](const CalibrationWindow& w) {
    return std::to_string(w.estimate.harmonic_first) + ".." + std::to_string(w.estimate.harmonic_last);
  });
  table.row("cells, 95 % in se", [](const CalibrationWindow& w) {
    char b[48];
    std::snprintf(b, sizeof b, "%.1f, %.3f", w.estimate.covariance_dof, w.estimate.parameters.interval_quantile);
    return std::string(b);
  });
  table.row("delay test-ref s", [](const CalibrationWindow& w) {
    return with_ci(w.estimate.delay_s, w.estimate.delay_ci95_s, 3);
  });
}

/// Rows of n's parameters and the trend, each with its 95 % half-width: scale ratios,
/// non-orthogonality, misalignment and axis deviation (deg), trend (nT/day).
void write_parameter_rows(const WindowColumns& table) {
  for (int l = 0; l < 3; ++l) {
    table.row(std::string("scale ratio K") + kAxes[l] + "t/K" + kAxes[l] + "r", [l](const CalibrationWindow& w) {
      return with_ci(w.estimate.parameters.scale_ratio(l), w.estimate.parameters.scale_ratio_ci95(l), 5);
    });
  }
  for (int k = 0; k < 3; ++k) {
    table.row(std::string("non-orthogonality ") + kAxisPairs[k] + " deg", [k](const CalibrationWindow& w) {
      return with_ci(w.estimate.parameters.nonorthogonality_deg(k), w.estimate.parameters.nonorthogonality_ci95_deg(k), 3);
    });
  }
  for (int l = 0; l < 3; ++l) {
    table.row(std::string("misalignment about ") + kAxes[l] + " deg", [l](const CalibrationWindow& w) {
      return with_ci(w.estimate.parameters.misalignment_deg(l), w.estimate.parameters.misalignment_ci95_deg(l), 3);
    });
  }
  for (int l = 0; l < 3; ++l) {
    table.row(std::string("axis deviation ") + kAxes[l] + " deg", [l](const CalibrationWindow& w) {
      return with_ci(w.estimate.parameters.axis_deviation_deg(l), w.estimate.parameters.axis_deviation_ci95_deg(l), 3);
    });
  }
  for (int l = 0; l < 3; ++l) {
    table.row(std::string("trend ") + kAxes[l] + " nT/day", [l](const CalibrationWindow& w) {
      return with_ci(w.estimate.trend_nT_per_day(l), kNormalQuantile95 * w.estimate.trend_stderr_nT_per_day(l), 2);
    });
  }
}

/// Rows of how well the model fits: coherence, residual rms (nT), and the relative response
/// over the band used: largest |gain - 1| and group delay (s) (relative_response.hpp).
void write_fit_rows(const WindowColumns& table) {
  table.row("coherence x/y/z", [](const CalibrationWindow& w) {
    char b[64];
    std::snprintf(b, sizeof b, "%.4f/%.4f/%.4f", w.estimate.coherence(0), w.estimate.coherence(1), w.estimate.coherence(2));
    return std::string(b);
  });
  table.row("residual rms x/y/z nT", [](const CalibrationWindow& w) {
    char b[64];
    std::snprintf(b, sizeof b, "%.3f/%.3f/%.3f", w.estimate.residual_rms_nT(0), w.estimate.residual_rms_nT(1),
                  w.estimate.residual_rms_nT(2));
    return std::string(b);
  });
  table.row("response |gain-1| max", [](const CalibrationWindow& w) {
    const auto r = summarise_response(w.relative_response, w.estimate.band_low_hz, w.estimate.band_high_hz);
    char b[48];
    if (r.bands == 0) return std::string("-");
    std::snprintf(b, sizeof b, "%.4f ± %.4f", r.max_gain_departure, r.max_gain_departure_ci95);
    return std::string(b);
  });
  table.row("response group delay s", [](const CalibrationWindow& w) {
    const auto r = summarise_response(w.relative_response, w.estimate.band_low_hz, w.estimate.band_high_hz);
    char b[32];
    if (r.bands == 0) return std::string("-");
    std::snprintf(b, sizeof b, "%.2f", r.group_delay_s);
    return std::string(b);
  });
}

/// Rows of the temperature terms when a window has them: the apparent coefficient (nT/degC,
/// what the record determines) and the scale's (ppm/degC); "-" for windows without.
void write_temperature_rows(const WindowColumns& table) {
  bool any_temperature = false;
  for (const auto& w : table.windows) any_temperature |= w.temperature.fitted;
  if (!any_temperature) return;
  for (int l = 0; l < 3; ++l) {
    table.row(std::string("temperature ") + kAxes[l] + " nT/degC", [l](const CalibrationWindow& w) {
      const TemperatureFit& t = w.temperature;
      return t.fitted ? with_ci(t.apparent_nT_per_C(l), t.apparent_ci95_nT_per_C(l), 3) : std::string("-");
    });
  }
  for (int l = 0; l < 3; ++l) {
    table.row(std::string("temperature ") + kAxes[l] + " ppm/degC", [l](const CalibrationWindow& w) {
      const TemperatureFit& t = w.temperature;
      return t.fitted ? with_ci(t.scale_ppm_per_C(l), t.scale_ci95_ppm_per_C(l), 0) : std::string("-");
    });
  }
}

/// Rows of the quality rules' inputs and verdict: condition number, quality.
void write_quality_rows(const WindowColumns& table) {
  table.row("condition number", [](const CalibrationWindow& w) {
    char b[32];
    std::snprintf(b, sizeof b, "%.1f", w.estimate.condition_number);
    return std::string(b);
  });
  table.row("quality", [](const CalibrationWindow& w) { return std::string(quality_name(w.estimate.quality)); });
}

/// What the pair alone is worth: against the remote's estimate when one was used (remote
/// reference), else its band's halves against each other (remote_reference.hpp).
std::string pair_alone(const WindowEstimate& e) {
  if (e.remote.used) return e.remote.pair_biased ? "biased (remote)" : "agrees (remote)";
  if (!e.band_split.assessed) return "-";
  return e.band_split.differs ? "halves differ" : "halves agree";
}

/// Rows of the remote reference (when any window has a remote) and of the pair-only checks.
void write_remote_rows(const WindowColumns& table, const std::vector<CalibrationWindow>& windows) {
  const bool remote = std::any_of(windows.begin(), windows.end(), [](const CalibrationWindow& w) {
    return w.estimate.remote.given;
  });
  if (remote) {
    table.row("remote F (used from 10)", [](const CalibrationWindow& w) {
      char b[48];
      std::snprintf(b, sizeof b, "%.0f%s", w.estimate.remote.strength, w.estimate.remote.used ? "" : " refused");
      return w.estimate.remote.given ? std::string(b) : std::string("-");
    });
  }
  table.row("pair alone", [](const CalibrationWindow& w) { return pair_alone(w.estimate); });
  if (std::any_of(windows.begin(), windows.end(), [](const CalibrationWindow& w) { return !w.scalar.text.empty(); })) {
    table.row("ref. scale along F", [](const CalibrationWindow& w) {
      return w.scalar.assessed ? with_ci(w.scalar.reference_scale, w.scalar.reference_scale_ci95, 5) : std::string("-");
    });
    table.row("test scale along F", [](const CalibrationWindow& w) {
      return w.scalar.assessed ? with_ci(w.scalar.test_scale, w.scalar.test_scale_ci95, 5) : std::string("-");
    });
  }
}

/// Under the table, one line per window and note: response model and reference noise, then
/// the temperature terms (when the record has a temperature channel), then why a window is not ok.
void write_window_notes(std::ostream& out, const PairCalibration& c) {
  for (const auto& w : c.windows) {
    if (w.response_model.fitted || !w.response_model.text.empty()) out << w.label << ": " << w.response_model.text << "\n";
    if (!w.reference_noise.text.empty()) out << w.label << ": " << w.reference_noise.text << "\n";
    if (w.estimate.remote.given) out << w.label << ": " << w.estimate.remote.text << "\n";
    if (w.estimate.band_split.differs) out << w.label << ": band split: " << w.estimate.band_split.text << "\n";
    if (!w.scalar.text.empty()) out << w.label << ": scalar: " << w.scalar.text << "\n";
  }
  for (const auto& w : c.windows) {
    if (!c.report.temperature_channel.empty()) out << w.label << ": " << w.temperature.text << "\n";
  }
  for (const auto& w : c.windows) {
    if (w.estimate.quality != Quality::kOk) out << w.label << ": " << w.estimate.quality_text << "\n";
  }
}

/// Many windows: one line each, n's parameters without intervals (deg for the angles).
void write_window_lines(std::ostream& out, const std::vector<CalibrationWindow>& windows) {
  out << "window          start (UTC)            scale ratio x/y/z            non-orth xy/xz/yz deg   "
         "misalignment x/y/z deg    quality\n";
  for (const auto& w : windows) {
    const auto& p = w.estimate.parameters;
    char line[512];
    std::snprintf(line, sizeof line,
                  "%-15s %-22s %.5f/%.5f/%.5f  %+.3f/%+.3f/%+.3f  %+.3f/%+.3f/%+.3f  %s\n", w.label.c_str(),
                  format_iso8601(w.start_s, 0).c_str(), p.scale_ratio(0), p.scale_ratio(1), p.scale_ratio(2),
                  p.nonorthogonality_deg(0), p.nonorthogonality_deg(1), p.nonorthogonality_deg(2),
                  p.misalignment_deg(0), p.misalignment_deg(1), p.misalignment_deg(2), quality_name(w.estimate.quality));
    out << line;
  }
}

}  // namespace

std::string format_calibration_table(const PairCalibration& c, const ReportInputs& inputs) {
  std::ostringstream out;
  write_header(out, c, inputs);
  if (c.windows.size() <= 6) {
    const WindowColumns table{out, c.windows};
    write_estimation_rows(table);
    write_parameter_rows(table);
    write_fit_rows(table);
    write_temperature_rows(table);
    write_quality_rows(table);
    write_remote_rows(table, c.windows);
    write_window_notes(out, c);
  } else {
    write_window_lines(out, c.windows);
  }
  // Whether the disjoint windows agree within their intervals (window_agreement.hpp).
  const std::vector<WindowEstimate> parts = disjoint_window_estimates(c.windows);
  if (!parts.empty()) out << "agreement of the windows: " << check_window_agreement(parts).text << "\n";
  return out.str();
}

}  // namespace magnetometer_insitu_calibration
