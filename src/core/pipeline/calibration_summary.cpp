// The report's summary: see calibration_summary.hpp.
#include "magnetometer_insitu_calibration/pipeline/calibration_summary.hpp"

#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "json_number.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace magnetometer_insitu_calibration {

namespace {

using nlohmann::json;

using json_detail::number;

/// "scale x", "non-orthogonality xy", "misalignment about z" from the parameter's key.
std::string words(const std::string& parameter) {
  const auto underscore = parameter.find('_');
  const std::string kind = parameter.substr(0, underscore), axes = parameter.substr(underscore + 1);
  if (kind == "scale") return "scale " + axes + " (ratio - 1)";
  if (kind == "nonorthogonality") return "non-orthogonality " + axes;
  return "misalignment about " + axes;
}

/// One verdict's row: value ± half-width and tolerance in % for a scale, deg for an angle.
std::string verdict_row(const ToleranceVerdict& v) {
  const bool scale = v.nominal == 1.0;
  const double unit = scale ? 100.0 : 1.0;
  const char* suffix = scale ? " %" : " deg";
  char value[64], tolerance[32];
  std::snprintf(value, sizeof value, "%+.3f ± %.3f%s", (v.value - v.nominal) * unit, v.ci95 * unit, suffix);
  std::snprintf(tolerance, sizeof tolerance, "%.3g%s", v.tolerance * unit, suffix);
  char row[256];
  std::snprintf(row, sizeof row, "  %-34s %-24s %-12s %-10s %s", words(v.parameter).c_str(), value, tolerance,
                verdict_name(v.verdict), record_length_text(v.record_needed_s).c_str());
  std::string text = row;
  text.erase(text.find_last_not_of(' ') + 1);  // a decided verdict has no record column
  return text + "\n";
}

/// n^-1 and the offset, stated as the correction of a test reading t (test frame, nT).
void write_correction(std::ostream& out, const CalibrationWindow& w) {
  const Eigen::Matrix3d inverse = w.estimate.n.inverse();
  out << "Correction: a test reading t (row, test frame, nT) in the reference frame is r = (t - d) n^-1, with\n";
  for (int i = 0; i < 3; ++i) {
    char line[160];
    std::snprintf(line, sizeof line, "  n^-1 row %d: %+.6f %+.6f %+.6f\n", i + 1, inverse(i, 0), inverse(i, 1),
                  inverse(i, 2));
    out << line;
  }
  char line[200];
  std::snprintf(line, sizeof line, "  d (the test's offset against the reference at the window's end): %.1f ± %.1f, %.1f ± %.1f, %.1f ± %.1f nT\n",
                w.offset_end_nT(0), w.offset_end_ci95_nT(0), w.offset_end_nT(1), w.offset_end_ci95_nT(1),
                w.offset_end_nT(2), w.offset_end_ci95_nT(2));
  out << line
      << "  archives: export_corrected --test TEST --calibration REPORT.json --window '" << w.label
      << "' --output OUT.sec (applies n; the baseline stays the observatory's)\n"
      << "  live: correction_node applies the calibration_node's latest calibration (n and d)\n";
}

/// What the verdicts rest on, when the window's own checks doubt it: nothing is written for a
/// window they vouch for.
void write_trust(std::ostream& out, const WindowEstimate& e) {
  if (e.remote.used && e.remote.pair_biased) {
    out << "The pair alone would have been biased (the pair sees a local disturbance the remote does not); n rests "
           "on the remote.\n";
  }
  const std::string why = not_vouched_for(e);
  if (why.empty()) return;
  out << "Not vouched for: " << why << ". A disturbance both sensors see biases n beyond its intervals and "
      << "the verdicts with it; give a remote observatory's record (--remote, ~remote_topic).\n";
}

}  // namespace

std::string not_vouched_for(const WindowEstimate& e) {
  if (e.remote.used) return "";
  std::string why;
  if (e.local_events.seen) why = "local events above the band that the test does not follow (traffic?)";
  // Halves that differ by more than the intervals carry (their spread is added to n's covariance).
  if (e.band_split.differs && !e.band_split.intervals_widened) {
    why += std::string(why.empty() ? "" : "; ") + "the band's halves differ";
  }
  return why;
}

const CalibrationWindow* summary_window(const PairCalibration& c) {
  if (c.windows.empty()) return nullptr;
  for (const auto& w : c.windows)
    if (w.label == kWholeRecordLabel) return &w;
  return &c.windows.back();
}

std::string format_calibration_summary(const PairCalibration& c, const Tolerances& tolerances) {
  std::ostringstream out;
  const CalibrationWindow* w = summary_window(c);
  if (w == nullptr) return "";
  // Without a whole-record window (sliding windows) the summary is of the latest one: said so.
  const std::string which = w->label == kWholeRecordLabel || c.windows.size() < 2
                                ? std::string()
                                : ", the latest of " + std::to_string(c.windows.size()) + " windows";
  char head[320];
  std::snprintf(head, sizeof head, "Summary of '%s' (%s to %s, %.1f h%s), quality %s\n", w->label.c_str(),
                format_iso8601(w->start_s, 0).c_str(), format_iso8601(w->end_s, 0).c_str(),
                (w->end_s - w->start_s) / 3600.0, which.c_str(), quality_name(w->estimate.quality));
  out << head << "Tolerances: " << tolerances.source << "\n";
  if (w->estimate.quality != Quality::kOk) {
    out << "The window is flagged: " << w->estimate.quality_text << ".\nA flagged window is not a calibration: "
        << "no verdicts, no correction to apply (the table below gives what was estimated, and why it failed).\n";
    const auto passed = std::count_if(c.windows.begin(), c.windows.end(), [](const CalibrationWindow& other) {
      return other.estimate.quality == Quality::kOk;
    });
    if (passed > 0) {
      out << passed << " of the other " << c.windows.size() - 1 << " windows passed their rules (the table below; "
          << "export_corrected --window LABEL applies one).\n";
    }
    if (w->scalar.assessed) out << "Against the scalar magnetometer: " << w->scalar.text << "\n";
    out << "\n";
    return out.str();
  }
  char columns[256];
  std::snprintf(columns, sizeof columns, "  %-34s %-24s %-12s %-10s %s\n", "parameter", "value ± 95 %", "tolerance",
                "verdict", "record that would decide");
  out << columns;
  for (const ToleranceVerdict& v : w->verdicts) out << verdict_row(v);
  if (!w->narrowing.text.empty()) {
    out << "Record needed, if the values stay where they are: intervals narrow as " << w->narrowing.text << "\n";
  }
  // The reference itself, when a scalar magnetometer checked it: a reference that departs from 1
  // makes every verdict above one against a wrong reference.
  if (w->scalar.assessed) out << "Against the scalar magnetometer: " << w->scalar.text << "\n";
  write_trust(out, w->estimate);
  write_correction(out, *w);
  out << "\n";
  return out.str();
}

json verdicts_to_json(const std::vector<ToleranceVerdict>& verdicts) {
  json out = json::array();
  for (const ToleranceVerdict& v : verdicts) {
    out.push_back(json{{"parameter", v.parameter},
                       {"value", number(v.value)},
                       {"ci95", number(v.ci95)},
                       {"nominal", v.nominal},
                       {"tolerance", v.tolerance},
                       {"verdict", verdict_name(v.verdict)},
                       {"record_needed_s", number(v.record_needed_s)},
                       {"record_needed", record_length_text(v.record_needed_s)}});
  }
  return out;
}

json tolerances_to_json(const Tolerances& t) {
  const auto three = [](const Eigen::Vector3d& v) { return json::array({v(0), v(1), v(2)}); };
  return json{{"source", t.source},
              {"scale", three(t.scale)},
              {"nonorthogonality_deg", three(t.nonorthogonality_deg)},
              {"misalignment_deg", three(t.misalignment_deg)}};
}

json narrowing_to_json(const IntervalNarrowing& n) {
  return json{{"exponent", number(n.exponent)},
              {"exponent_se", number(n.exponent_se)},
              {"sub_windows", n.sub_windows},
              {"text", n.text}};
}

}  // namespace magnetometer_insitu_calibration
