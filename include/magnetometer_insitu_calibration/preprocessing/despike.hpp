// Spike removal: a Hampel-type detector on running medians, one component at a time.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <cstddef>

namespace magnetometer_insitu_calibration {

/// Rule, for each column c of the readings and each sample i (w = half_window):
///   median_i    = median of the finite values x[j], |j - i| <= w (window clipped at the ends)
///   residual_i  = x[i] - median_i                                               (nT)
///   mad_i       = median of |residual_j|, |j - i| <= w, finite ones only         (nT)
///                 (a running MAD: the residuals' own median is ~0 by construction)
///   curvature_i = |median_{i-w} - 2 median_i + median_{i+w}|  (lag shortened near the ends) (nT)
///   x[i] is a spike when
///     |residual_i| > max(threshold * 1.4826 * mad_i, min_threshold_nT, curvature_i).
/// 1.4826 * MAD estimates the standard deviation of Gaussian noise, so `threshold` is in
/// "sigmas". A median over 2w+1 samples passes any monotonic stretch unchanged, so smooth
/// geomagnetic variations give residuals near zero; bursts of up to w samples are removed.
/// The floor min_threshold_nT keeps quantised or very quiet data (mad = 0) from turning noise
/// into spikes. The curvature term is an addition to the plain Hampel rule: at the crest of a
/// fast oscillation the median cuts the top (by 0.63 nT for 20 nT at a 20 s period, 10 Hz,
/// w = 15) on fewer than w samples, so the MAD stays 0 and the floor alone would flag real
/// signal; that cut is below a third of curvature_i for periods above ~5 s at w = 15, while
/// the median itself, and so curvature_i, ignores spikes. Flags need at least three finite
/// values in the window.
struct DespikeSettings {
  std::size_t half_window = 15;   ///< w, samples each side (31 samples = 3.1 s at 10 Hz)
  double threshold = 8.0;         ///< multiple of 1.4826 * MAD
  double min_threshold_nT = 0.5;  ///< smallest |residual| that can be a spike, nT

  /// Throws InputError naming the field when a value is impossible.
  void validate() const;
};

/// Sets the spikes of every column to NaN (in place; other columns of the same row are kept).
/// Values that are already NaN are skipped and not counted. Returns the number of values
/// (row, column) set to NaN. O(N log w) time, O(w) extra memory besides two N-vectors.
std::size_t despike(Readings& values, const DespikeSettings& settings);

}  // namespace magnetometer_insitu_calibration
