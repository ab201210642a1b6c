// Verdicts against tolerances and the record length that would decide: see tolerance_verdicts.hpp.
#include "magnetometer_insitu_calibration/pipeline/tolerance_verdicts.hpp"

#include <cmath>
#include <algorithm>
#include <cstdio>
#include <sstream>

namespace magnetometer_insitu_calibration {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// The nine half-widths in a fixed order: scale x, y, z; non-orthogonality xy, xz, yz;
/// misalignment x, y, z.
Eigen::Matrix<double, 9, 1> half_widths(const CalibrationParameters& p) {
  Eigen::Matrix<double, 9, 1> c;
  c << p.scale_ratio_ci95, p.nonorthogonality_ci95_deg, p.misalignment_ci95_deg;
  return c;
}

}  // namespace

const char* verdict_name(Verdict v) {
  switch (v) {
    case Verdict::kWithin: return "within";
    case Verdict::kOutside: return "outside";
    case Verdict::kUndecided: return "undecided";
  }
  return "undecided";
}

Verdict decide(double value, double ci95, double nominal, double tolerance) {
  const double d = std::abs(value - nominal);
  if (!std::isfinite(d) || !std::isfinite(ci95)) return Verdict::kUndecided;
  if (d + ci95 <= tolerance) return Verdict::kWithin;
  if (d - ci95 > tolerance) return Verdict::kOutside;
  return Verdict::kUndecided;
}

std::vector<ToleranceVerdict> tolerance_verdicts(const CalibrationParameters& p, const Tolerances& tolerances,
                                                 double window_s, const IntervalNarrowing& narrowing) {
  static const char* const kNames[9] = {"scale_x",           "scale_y",           "scale_z",
                                        "nonorthogonality_xy", "nonorthogonality_xz", "nonorthogonality_yz",
                                        "misalignment_x",    "misalignment_y",    "misalignment_z"};
  Eigen::Matrix<double, 9, 1> value, tolerance;
  value << p.scale_ratio, p.nonorthogonality_deg, p.misalignment_deg;
  tolerance << tolerances.scale, tolerances.nonorthogonality_deg, tolerances.misalignment_deg;
  const Eigen::Matrix<double, 9, 1> ci = half_widths(p);
  std::vector<ToleranceVerdict> out;
  for (int k = 0; k < 9; ++k) {
    ToleranceVerdict v;
    v.parameter = kNames[k];
    v.value = value(k);
    v.ci95 = ci(k);
    v.nominal = k < 3 ? 1.0 : 0.0;
    v.tolerance = tolerance(k);
    v.verdict = decide(v.value, v.ci95, v.nominal, v.tolerance);
    if (v.verdict == Verdict::kUndecided && narrowing.measured()) {
      const double needed_half_width = std::abs(v.tolerance - std::abs(v.value - v.nominal));
      if (narrowing.exponent < kMinNarrowingExponent || !(needed_half_width > 0.0)) {
        v.record_needed_s = kInf;
      } else {
        v.record_needed_s = window_s * std::pow(v.ci95 / needed_half_width, 1.0 / narrowing.exponent);
      }
    }
    out.push_back(v);
  }
  return out;
}

IntervalNarrowing measure_interval_narrowing(WindowEstimator& estimator, const PairedRecord& filled, double period_s,
                                             const WindowInputs& inputs, const CalibrationParameters& whole) {
  IntervalNarrowing out;
  const Eigen::Matrix<double, 9, 1> c_whole = half_widths(whole);
  const Eigen::Index n = filled.reference_nT.rows();
  double sxy = 0.0, sxx = 0.0;
  std::vector<double> per_sub_window;  // each sub-window's own exponent: mean log ratio / log parts
  std::string failed;
  // A sub-window shorter than two periods of the band's lowest frequency resolves less of the
  // band than the window: its interval is wider for that, not for its length alone.
  const double min_length_s = 2.0 / estimator.settings().band_low_hz;
  if (static_cast<double>(n / 2) * period_s < min_length_s) {
    std::ostringstream text;
    text << "not measured: the window's halves are shorter than 2 / band_low (" << min_length_s << " s)";
    out.text = text.str();
    return out;
  }
  for (int parts : {2, 4}) {
    const Eigen::Index length = n / parts;
    if (static_cast<double>(length) * period_s < min_length_s) continue;
    for (int k = 0; k < parts; ++k) {
      const Eigen::Index first = k * length;
      WindowInputs sub_inputs = inputs;
      Readings remote;
      if (inputs.remote_nT != nullptr) {
        remote = inputs.remote_nT->middleRows(first, length);
        sub_inputs.remote_nT = &remote;
      }
      const WindowEstimate e = estimator.estimate(filled.reference_nT.middleRows(first, length),
                                                  filled.test_nT.middleRows(first, length), period_s, sub_inputs);
      if (e.quality != Quality::kOk) {
        if (failed.empty()) failed = e.quality_text;
        continue;
      }
      const Eigen::Matrix<double, 9, 1> c = half_widths(e.parameters);
      const double x = std::log(static_cast<double>(parts));
      double sum_y = 0.0;
      int count = 0;
      for (int j = 0; j < 9; ++j) {
        if (!(c(j) > 0.0) || !(c_whole(j) > 0.0) || !std::isfinite(c(j)) || !std::isfinite(c_whole(j))) continue;
        const double y = std::log(c(j) / c_whole(j));
        sxy += x * y;
        sxx += x * x;
        sum_y += y;
        ++count;
      }
      if (count > 0) per_sub_window.push_back(sum_y / count / x);
    }
  }
  out.sub_windows = static_cast<int>(per_sub_window.size());
  if (out.sub_windows == 0 || sxx <= 0.0) {
    out.text = "not measured: no half or quarter of the window gives an estimate (" +
               (failed.empty() ? std::string("no finite interval") : failed) + ")";
    return out;
  }
  out.exponent = sxy / sxx;  // least squares through the origin: c_sub / c_whole = parts^a
  // The nine parameters of one sub-window share its signal: the scatter is that of the
  // sub-windows' own exponents.
  if (out.sub_windows >= 2) {
    double mean = 0.0, ss = 0.0;
    for (double a : per_sub_window) mean += a / out.sub_windows;
    for (double a : per_sub_window) ss += (a - mean) * (a - mean);
    out.exponent_se = std::sqrt(ss / (out.sub_windows - 1) / out.sub_windows);
  }
  std::ostringstream text;
  text.precision(2);
  text << std::fixed << "half-widths ~ length^-" << out.exponent << " (+- " << out.exponent_se << " se) from "
       << out.sub_windows << " halves and quarters of at least 2 / band_low";
  out.text = text.str();
  return out;
}

std::vector<VerdictGroup> group_verdicts(const std::vector<ToleranceVerdict>& verdicts) {
  static const char* const kGroups[3] = {"scale", "non-orthogonality", "misalignment"};
  std::vector<VerdictGroup> out;
  for (std::size_t g = 0; g < 3 && verdicts.size() >= 3 * (g + 1); ++g) {
    VerdictGroup group;
    group.name = kGroups[g];
    std::string lists[3];  // within, outside, undecided
    for (std::size_t k = 3 * g; k < 3 * g + 3; ++k) {
      const ToleranceVerdict& v = verdicts[k];
      const std::string axes = v.parameter.substr(v.parameter.find('_') + 1);
      std::string& list = lists[static_cast<int>(v.verdict)];
      list += (list.empty() ? "" : ", ") + axes;
      if (v.verdict == Verdict::kUndecided && !std::isnan(v.record_needed_s))
        list += " (record " + record_length_text(v.record_needed_s) + ")";
      if (v.verdict == Verdict::kOutside) group.worst = Verdict::kOutside;
      if (v.verdict == Verdict::kUndecided && group.worst == Verdict::kWithin) group.worst = Verdict::kUndecided;
    }
    for (Verdict v : {Verdict::kOutside, Verdict::kUndecided, Verdict::kWithin}) {
      const std::string& list = lists[static_cast<int>(v)];
      if (!list.empty()) group.text += (group.text.empty() ? "" : "; ") + std::string(verdict_name(v)) + ": " + list;
    }
    out.push_back(group);
  }
  return out;
}

std::string record_length_text(double seconds) {
  if (std::isnan(seconds)) return "";
  if (std::isinf(seconds)) return "no record length of this kind";
  char b[64];
  const double days = seconds / 86400.0;
  if (days > 365.0) return "more than a year";
  if (days >= 2.0) std::snprintf(b, sizeof b, "%.1f days", days);
  else std::snprintf(b, sizeof b, "%.0f h", std::ceil(seconds / 3600.0));
  return b;
}

}  // namespace magnetometer_insitu_calibration
