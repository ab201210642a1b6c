// The table report of a pair calibration (calibrate_records' terminal output after the summary):
// see calibration_report.hpp.
#include "magnetometer_insitu_calibration/pipeline/calibration_report.hpp"

#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/estimation/window_agreement.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace magnetometer_insitu_calibration {


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

/// How the records came onto common epochs, as the pre-processing line's clause ("" when paired
/// by stamp at their own rate).
std::string epoch_alignment_text(const PreprocessReport& r) {
  char text[200];
  switch (r.alignment) {
    case EpochAlignment::kPairedStamps: return "";
    case EpochAlignment::kPairedThenDecimated: return ", Gaussian FIR decimated";
    case EpochAlignment::kEachFiltered:
      if (r.stamp_offset_s == 0.0) {  // measured at one rate only
        std::snprintf(text, sizeof text, ", each record Gaussian-FIR filtered onto common epochs (two rates: %.3g s and %.3g s)",
                      r.reference_period_s, r.test_period_s);
      } else {
        std::snprintf(text, sizeof text,
                      ", each record Gaussian-FIR filtered onto common epochs (the test's stamps %+.3g s off the reference's)",
                      r.stamp_offset_s);
      }
      return text;
  }
  return "";
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
      << r.spikes_test << epoch_alignment_text(r) << ", " << r.grid_samples
      << " samples on the grid, " << r.missing_samples << " missing (filled in the windows), " << r.long_gaps
      << " long gaps\n";
  // One model for every window in full; a model identified in each window by its source only
  // (each window's own figures are among the notes).
  std::vector<std::string> models =
      distinct_texts(c.windows, [](const CalibrationWindow& w) { return w.estimate.eiv_text(); });
  if (models.size() > 1) {
    models = distinct_texts(c.windows, [](const CalibrationWindow& w) {
      return std::string(errors_in_variables_name(w.estimate.eiv)) + ", reference noise: " +
             noise_source_name(w.estimate.eiv_noise.source) + " (identified in each window: notes)";
    });
  }
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
/// reference), else its band's halves against each other (remote_reference.hpp) and the events
/// above the band (local_event_check.hpp).
std::string pair_alone(const WindowEstimate& e) {
  if (e.remote.used) return e.remote.pair_biased ? "biased (remote)" : "agrees (remote)";
  std::string text;
  if (e.band_split.assessed) text = e.band_split.differs ? "halves differ" : "halves agree";
  if (e.band_split.intervals_widened) text += " (spread carried)";
  if (e.local_events.assessed) text += std::string(text.empty() ? "" : ", ") + (e.local_events.seen ? "events" : "no events");
  return text.empty() ? "-" : text;
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

/// Notes of the windows, each text once with the labels of the windows it belongs to.
struct WindowNotes {
  std::vector<std::pair<std::string, std::string>> notes;  // (text, labels)
  void add(const std::string& label, const std::string& text) {
    for (auto& [t, labels] : notes) {
      if (t == text) {
        labels += ", " + label;
        return;
      }
    }
    notes.emplace_back(text, label);
  }
  void write(std::ostream& out) const {
    for (const auto& [text, labels] : notes) out << labels << ": " << text << "\n";
  }
};

/// Under the table, the notes (a text shared by several windows once): response model and
/// reference noise, remote, band split and scalar check, then the temperature terms (when the
/// record has a temperature channel), then why a window is not ok.
void write_window_notes(std::ostream& out, const PairCalibration& c) {
  WindowNotes notes;
  for (const auto& w : c.windows) {
    if (w.response_model.fitted || !w.response_model.text.empty()) notes.add(w.label, w.response_model.text);
    if (!w.reference_noise.text.empty()) notes.add(w.label, w.reference_noise.text);
    if (w.estimate.remote.given) notes.add(w.label, w.estimate.remote.text);
    if (w.estimate.band_split.differs || w.estimate.band_split.intervals_widened) notes.add(w.label, "band split: " + w.estimate.band_split.text);
    if (w.estimate.local_events.seen) notes.add(w.label, "local events: " + w.estimate.local_events.text);
    if (!w.scalar.text.empty()) notes.add(w.label, "scalar: " + w.scalar.text);
  }
  for (const auto& w : c.windows) {
    if (!c.report.temperature_channel.empty()) notes.add(w.label, w.temperature.text);
  }
  for (const auto& w : c.windows) {
    if (w.estimate.quality != Quality::kOk) notes.add(w.label, w.estimate.quality_text);
  }
  notes.write(out);
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
    out << "Each window: what it is and how it was estimated\n";
    write_estimation_rows(table);
    out << "The test's parameters against the reference\n";
    write_parameter_rows(table);
    out << "How well T = R n fits\n";
    write_fit_rows(table);
    write_temperature_rows(table);
    out << "Checks\n";
    write_quality_rows(table);
    write_remote_rows(table, c.windows);
    out << "Notes\n";
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
