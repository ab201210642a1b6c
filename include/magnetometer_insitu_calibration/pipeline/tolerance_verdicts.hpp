// The three questions an observatory engineer asks of a window, answered from its estimate:
// is each parameter within its tolerance (common/tolerances.hpp), and if the interval cannot
// tell yet, how long a record would.
//
// Verdict of a parameter with value v, 95 % half-width c, nominal v0 (1 for a scale ratio, 0
// for an angle) and tolerance t, d = |v - v0|:
//   within     d + c <= t   (the whole interval inside the tolerance)
//   outside    d - c >  t   (the whole interval outside)
//   undecided  otherwise.
// An undecided parameter is decided once its half-width falls to h = |t - d| (if the value
// stays where it is). How a half-width narrows with record length is measured on the window
// itself: its halves and quarters (those at least two periods of the band's lowest frequency
// long, which resolve the band as the window does) are estimated with the window's own
// estimator and inputs, and c(L) ~ L^-a is fitted through them (the exponent a pooled over the nine parameters: a = 1/2
// when the signal and the noise are as strong in every part of the record; less when the
// record's signal comes in bursts). The record needed is then L (c / h)^(1/a).
#pragma once

#include "magnetometer_insitu_calibration/common/tolerances.hpp"
#include "magnetometer_insitu_calibration/estimation/window_estimator.hpp"
#include "magnetometer_insitu_calibration/preprocessing/time_alignment.hpp"

#include <limits>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

enum class Verdict { kWithin, kOutside, kUndecided };
const char* verdict_name(Verdict v);  ///< "within", "outside", "undecided"

/// c(L) ~ L^-exponent, measured on a window's sub-windows.
struct IntervalNarrowing {
  double exponent = std::numeric_limits<double>::quiet_NaN();
  double exponent_se = std::numeric_limits<double>::quiet_NaN();  ///< from the scatter of the sub-windows' ratios
  int sub_windows = 0;  ///< sub-window estimates used (of up to 6: two halves, four quarters)
  std::string text;     ///< how it was measured, or why it was not

  bool measured() const { return sub_windows > 0 && std::isfinite(exponent); }
};

/// Below this exponent a longer record of the same kind is not taken to narrow the interval.
constexpr double kMinNarrowingExponent = 0.1;

struct ToleranceVerdict {
  std::string parameter;  ///< scale_x .. scale_z, nonorthogonality_xy/xz/yz, misalignment_x/y/z
  double value = 0.0;     ///< scale ratio, or degrees
  double ci95 = 0.0;      ///< half-width of the 95 % interval, same unit
  double nominal = 0.0;   ///< 1 for a scale ratio, 0 for an angle
  double tolerance = 0.0; ///< largest |value - nominal|, same unit
  Verdict verdict = Verdict::kUndecided;
  /// Undecided: the record length (s) at which the interval would decide if the value stays;
  /// infinity when no length of such a record decides (the value at the tolerance's edge, or
  /// an interval that does not narrow); NaN when decided or not measured.
  double record_needed_s = std::numeric_limits<double>::quiet_NaN();
};

/// The verdict rule above for one parameter.
Verdict decide(double value, double ci95, double nominal, double tolerance);

/// The nine verdicts of a window of length window_s (s) from its parameters; record_needed_s
/// from the narrowing when it is measured.
std::vector<ToleranceVerdict> tolerance_verdicts(const CalibrationParameters& p, const Tolerances& tolerances,
                                                 double window_s, const IntervalNarrowing& narrowing);

/// Estimates the window's two halves and four quarters of `filled` (regular, gap-free, period_s)
/// with `estimator` and `inputs` (a remote sliced with them) and fits the exponent against the
/// half-widths of `whole`, the same estimator's estimate of the whole window. Sub-windows that
/// fail a quality rule, and sizes shorter than 2 / band_low, are left out; none left: not
/// measured, with the reason.
IntervalNarrowing measure_interval_narrowing(WindowEstimator& estimator, const PairedRecord& filled, double period_s,
                                             const WindowInputs& inputs, const CalibrationParameters& whole);

/// The verdicts of one parameter group (scale, non-orthogonality, misalignment): the worst
/// (outside before undecided before within) and the group in words, e.g.
/// "within: x, y; undecided: z (record 3.2 days)".
struct VerdictGroup {
  std::string name;  ///< "scale", "non-orthogonality", "misalignment"
  Verdict worst = Verdict::kWithin;
  std::string text;
};
/// The three groups of tolerance_verdicts()' nine; empty for no verdicts.
std::vector<VerdictGroup> group_verdicts(const std::vector<ToleranceVerdict>& verdicts);

/// "3.2 days", "7 h", "more than a year", "no record length" for a record_needed_s.
std::string record_length_text(double seconds);

}  // namespace magnetometer_insitu_calibration
