// Eq. 2's whole-window fits of the robust estimator on the records averaged in pairs of samples
// (robust_estimator.cpp, plain_fit): when, and how. Not installed: src/core only.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"

#include <algorithm>
#include <cstddef>

namespace magnetometer_insitu_calibration::detail {

/// Whether Eq. 2's whole-window fits (n0 for the screen, the trend, the delay's spectra) are made
/// on the records averaged in pairs of samples (an odd last sample left out), which halves their
/// transforms: when the band and the delay's top frequency are at most half the averages' Nyquist
/// frequency, where the average passes both records alike (its gain cos(pi f dt): 0.95 at 0.1 Hz
/// on 1 s records, the same in R and T, so that n, the trend and the delay's phase keep their
/// meaning). The cells, and so n and its intervals, are the full records' either way.
inline bool fits_on_pairs(std::size_t length, double period_s, const EstimatorSettings& settings) {
  const double nyquist_of_pairs = 0.25 / period_s;  // Hz
  return length >= 256 && std::max(settings.band_high_hz, settings.robust.delay_max_hz) <= 0.5 * nyquist_of_pairs;
}

/// x averaged in pairs of samples into out (rows / 2 rows; an odd last row left out).
inline void average_pairs(const Eigen::Ref<const Readings>& x, Readings& out) {
  const Eigen::Index half = x.rows() / 2;
  out.resize(half, 3);
  for (int c = 0; c < 3; ++c) {  // column by column: contiguous in both
    const double* in = x.col(c).data();
    const Eigen::Index stride = x.col(c).innerStride();
    double* o = out.col(c).data();
    for (Eigen::Index i = 0; i < half; ++i) o[i] = 0.5 * (in[2 * i * stride] + in[(2 * i + 1) * stride]);
  }
}

}  // namespace magnetometer_insitu_calibration::detail
