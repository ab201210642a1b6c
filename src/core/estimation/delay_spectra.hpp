// The delay estimator's spectra (delay_estimation.hpp) from a record's own whole-window DFT,
// without a transform of their own. Not installed: src/core only.
//
// For one column x_0 .. x_{N-1} (nT) the delay wants the DFT (length N, bins j at j / (N dt)) of
//   q_i = h_i (d_i - a - b (i - c)),  d_i = x_{i+1} - x_i  (i = 0 .. N-2),  q_{N-1} = 0,
// the first differences, detrended by their least-squares line a + b (i - c), c = (N - 2) / 2,
// zero-padded to N and tapered by h_i = 0.5 - 0.5 cos(2 pi (i + 1/2) / N). Each step is exact
// in the frequency domain, with X the DFT of x, z = e^{-2 pi i j / N} and w = 1 / z:
//   D(j) = (w - 1) X(j) + w (x_{N-1} - x_0)                     (differences, wrap term removed)
//   L0(j) = sum_{i<N-1} z^i = -w,  L1(j) = sum_{i<N-1} (i - c) z^i = N / (z - 1) - (N - 1 - c) w
//   Q(j) = D(j) - a L0(j) - b L1(j)                               (j != 0)
//   H(j) = 0.5 Q(j) - 0.25 u Q(j - 1) - 0.25 u^* Q(j + 1),  u = e^{i pi / N}   (the taper)
// with a = (x_{N-1} - x_0) / (N - 1) and b = [c (x_{N-1} - x_0) - S] / [M (M^2 - 1) / 12],
// M = N - 1, S = sum_{i=1}^{N-2} (x_i - x_0) (summation by parts of sum (i - c) d_i). A constant
// added to x changes none of them, so the spectra of Eq. 2's centred columns serve as they are.
#pragma once

#include <Eigen/Core>

#include <cmath>
#include <complex>
#include <cstddef>
#include <vector>

namespace magnetometer_insitu_calibration::detail {

/// The time-domain figures of one column the differencing and detrending need (nT): its first and
/// last value and S = sum_{i=1}^{N-2} (x_i - x_0). Linear in x, so those of R n are n's
/// combinations of R's.
struct ColumnEnds {
  double first = 0.0, last = 0.0, interior_sum = 0.0;
};

template <typename Column>
ColumnEnds column_ends(const Column& x) {
  ColumnEnds e;
  const Eigen::Index n = x.size();
  if (n == 0) return e;
  e.first = x(0);
  e.last = x(n - 1);
  double s[4] = {0.0, 0.0, 0.0, 0.0};  // four running sums: independent additions
  Eigen::Index i = 1;
  for (; i + 4 < n; i += 4)
    for (int k = 0; k < 4; ++k) s[k] += x(i + k) - e.first;
  for (; i + 1 < n; ++i) s[0] += x(i) - e.first;
  e.interior_sum = (s[0] + s[1]) + (s[2] + s[3]);
  return e;
}

/// The factors of D, L0 and L1 above that depend only on j and N, for j = j_first - 1 ..
/// j_last + 1 (index j - j_first + 1): computed once per window for all six columns.
/// 1 / (z - 1) = -1/2 + (i/2) cot(pi j / N): no complex division.
struct DifferenceKernel {
  std::size_t length = 0;
  long j_first = 0, j_last = 0;
  std::vector<std::complex<double>> w, l1;

  void prepare(std::size_t n_samples, long first, long last) {
    if (n_samples == length && first == j_first && last == j_last) return;
    length = n_samples;
    j_first = first;
    j_last = last;
    const double n = static_cast<double>(n_samples);
    const double c = 0.5 * (n - 2.0);
    const std::size_t count = static_cast<std::size_t>(last - first + 3);
    w.resize(count);
    l1.resize(count);
    for (std::size_t k = 0; k < count; ++k) {
      const double half = M_PI * static_cast<double>(first - 1 + static_cast<long>(k)) / n;  // theta / 2
      w[k] = std::polar(1.0, 2.0 * half);
      l1[k] = n * std::complex<double>(-0.5, 0.5 / std::tan(half)) - (n - 1.0 - c) * w[k];
    }
  }
};

/// H(j) for j = j_first .. j_last of `kernel` (1 < j_first, j_last < N / 2) into out[0 ..],
/// from x_bins[k] = X(j_first - 1 + k), k = 0 .. j_last - j_first + 2 (X at j_first - 1 ..
/// j_last + 1).
inline void tapered_difference_spectrum(const std::complex<double>* x_bins, const ColumnEnds& ends,
                                        const DifferenceKernel& kernel, std::complex<double>* out) {
  const double n = static_cast<double>(kernel.length);
  const double m = n - 1.0;
  const double c = 0.5 * (n - 2.0);
  const double rise = ends.last - ends.first;
  const double a = rise / m;
  const double b = (c * rise - ends.interior_sum) / (m * (m * m - 1.0) / 12.0);
  // Q = (w - 1) X + w rise - a L0 - b L1 with L0 = -w.
  const auto q = [&](std::size_t k) { return (kernel.w[k] - 1.0) * x_bins[k] + kernel.w[k] * (rise + a) - b * kernel.l1[k]; };
  const std::complex<double> u = std::polar(0.25, M_PI / n);
  std::complex<double> below = q(0), here = q(1);
  const std::size_t count = static_cast<std::size_t>(kernel.j_last - kernel.j_first + 1);
  for (std::size_t k = 0; k < count; ++k) {
    const std::complex<double> above = q(k + 2);
    out[k] = 0.5 * here - u * below - std::conj(u) * above;
    below = here;
    here = above;
  }
}

}  // namespace magnetometer_insitu_calibration::detail

#include "magnetometer_insitu_calibration/estimation/delay_estimation.hpp"

#include <array>

namespace magnetometer_insitu_calibration::detail {

/// A window's whole-record DFTs (length N, bins j = 0 .. N/2, FFTW's convention) of R's three
/// columns then T's, with their ColumnEnds: what estimate_delay_from_spectra needs.
struct WholeWindowSpectra {
  std::size_t length = 0;
  std::array<const std::complex<double>*, 6> bins{};
  std::array<ColumnEnds, 6> ends{};
};

/// estimate_delay (delay_estimation.hpp) on spectra already computed: no transform.
DelayEstimate estimate_delay_from_spectra(const WholeWindowSpectra& spectra, const Eigen::Matrix3d& n,
                                          double sample_period_s, const DelaySettings& settings);

}  // namespace magnetometer_insitu_calibration::detail
