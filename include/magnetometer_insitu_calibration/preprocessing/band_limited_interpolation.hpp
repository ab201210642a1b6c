// A regular record between its samples, by windowed-sinc (Lanczos) interpolation: what a
// band-limited record was at an instant off its grid. The scalar check puts the 1 s reference at
// a 30 s scalar magnetometer's instants with it, and the simulated scalar reads the simulated
// field with it.
//
// Why not a straight line or a cubic. A scalar sampled every 30 s folds the field between its
// Nyquist frequency (0.017 Hz) and the reference grid's (0.5 Hz) into the calibration band; under
// an f^-2 field spectrum the folded part is 7 % of the in-band signal at 0.005 Hz and 35 % at
// 0.01 Hz. The scalar folds the true field, so the reference at the same instants must fold the
// same field: its interpolation must pass it up to near 0.5 Hz. At 0.37 s from a sample a
// straight line loses 4.6 % of the amplitude at 0.1 Hz and 38 % at 0.3 Hz, a Catmull-Rom cubic
// 0.3 % and 19 %, Lanczos with 16 samples each side 0.02 % and 0.1 % (2 % at 0.45 Hz).
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <vector>

namespace magnetometer_insitu_calibration {

/// Samples on each side of the point that the scalar check's interpolation uses.
constexpr int kLanczosHalfWidth = 16;

/// The 2 a weights on samples i - a + 1 .. i + a of a point at fraction u (0 <= u < 1) of the
/// step after sample i, a = half_width (>= 1): L(u - k) = sinc(u - k) sinc((u - k) / a),
/// normalised to sum 1 (a constant passes unchanged). u = 0: sample i alone.
std::vector<double> lanczos_weights(double u, int half_width);

/// A record on the regular grid t0_s + k period_s (rows k; NaN = missing) at the times `at`
/// (s): Lanczos interpolation with half_width samples each side, indices beyond the record held
/// at its first or last row; NaN where `at` is outside the record or a weight falls on a
/// missing row. Throws std::invalid_argument for a period <= 0 or half_width < 1.
Readings interpolate_regular(const Readings& values, double t0_s, double period_s, const std::vector<double>& at,
                             int half_width = kLanczosHalfWidth);

/// How the interpolation at `at` (times on a record of period_s from t0_s) and the resampling to
/// the regular step resample_period_s (> period_s) pass the record's own noise:
/// - white_variance: the mean over the points of the sum of squared weights (white noise of
///   variance s^2 per sample has s^2 white_variance at a point);
/// - pink_alias: sum over m of mean |H(m / resample_period_s)|^2 / m, for m / resample_period_s
///   below the grid's Nyquist frequency, H the interpolation's response: 1/f noise of PSD p^2 / f
///   folds into the low band as white of variance p^2 pink_alias per resampled point.
struct InterpolatedNoise {
  double white_variance = 1.0;
  double pink_alias = 0.0;
};
InterpolatedNoise interpolated_noise(double t0_s, double period_s, const std::vector<double>& at,
                                     double resample_period_s, int half_width = kLanczosHalfWidth);

}  // namespace magnetometer_insitu_calibration
