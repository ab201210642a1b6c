// The paper's linear-trend column, section by section, for the robust estimator's cells
// (robust_estimator.hpp, step 2). Not installed: src/core only.
//
// Why. Each section is detrended in time (least-squares line) before its DFT, but an untapered
// DFT sees the section as one period of a periodic record: what differs between its two ends
// (the line's fit leaves end values of a random walk apart by about its increment) leaks into
// every harmonic as the DFT of a ramp, r_j ~ N / (2 pi i j), with one real coefficient per
// section and component. A residual that drifts, such as one pier's tilt (a 1/f^2 random walk
// seen by one sensor), thus puts a component into a section's cells that is coherent over all
// its harmonics: the cells are not independent, which the sandwich and a jackknife over
// interleaved frequency groups assume (measured, monte_carlo_unmodelled disturbed 200 0.25
// 11000, no EIV: errors 1.39-1.49 standard errors rms for the scale ratios, 1.15 without the
// tilt; plain Eq. 2, whose trend column is this ramp over the whole window, 1.11-1.12).
// Eq. 2's trend column, applied per section, removes it (the same runs: 1.04-1.07 for the x and
// y scale ratios, coverage of the six parameters 86.2 -> 93.2 %; docs/validation.md,
// design choices): by Frisch-Waugh-Lovell, fitting
// n together with a real coefficient on r per section and component is fitting n to the cells
// with r projected out of every column of X and Y.
#pragma once

#include "section_cells.hpp"

#include <complex>
#include <cmath>
#include <cstddef>
#include <vector>

namespace magnetometer_insitu_calibration::detail::robust {

/// DFT at harmonic j (1 <= j < length) of the ramp t = 0 .. length - 1, with FFTW's sign
/// (sum_t t e^{-2 pi i j t / length}): -length / (1 - e^{-2 pi i j / length}). Samples.
inline std::complex<double> ramp_dft(long j, std::size_t length) {
  const double n = static_cast<double>(length);
  const double w = 2.0 * M_PI * static_cast<double>(j) / n;
  return -n / (std::complex<double>(1.0, 0.0) - std::polar(1.0, -w));
}

/// Removes, from the cells [first, last) of one section (all of one length), each column's
/// component along the ramp's DFT: v <- v - beta r, beta = sum g Re(conj(r) v) / sum g |r|^2
/// (real: the trend of a real record), the inner product of Eq. 2 with weights g = lambda^gamma.
/// Columns that are zero (the reference's, when only the test was transformed) stay zero. The
/// remote's columns (cell.z) with with_remote: it is an instrument of the same regression, and
/// the same projection keeps its own drift out of the low harmonics.
inline void remove_section_trend(std::vector<Cell>& cells, std::size_t first, std::size_t last,
                                 bool with_remote = false) {
  if (last <= first + 1) return;  // one harmonic: the trend would take all of it
  const std::size_t length = cells[first].length;
  std::vector<std::complex<double>> r(last - first);
  double rr = 0.0;
  for (std::size_t i = first; i < last; ++i) {
    r[i - first] = ramp_dft(cells[i].harmonic, length);
    rr += cells[i].g * std::norm(r[i - first]);
  }
  if (!(rr > 0.0)) return;
  auto column = [](Cell& cell, int k) -> std::complex<double>& {
    return k < 3 ? cell.x(k) : (k < 6 ? cell.y(k - 3) : cell.z(k - 6));
  };
  for (int k = 0; k < (with_remote ? 9 : 6); ++k) {
    double num = 0.0;
    for (std::size_t i = first; i < last; ++i) num += cells[i].g * (std::conj(r[i - first]) * column(cells[i], k)).real();
    const double beta = num / rr;
    for (std::size_t i = first; i < last; ++i) column(cells[i], k) -= beta * r[i - first];
  }
}

}  // namespace magnetometer_insitu_calibration::detail::robust
