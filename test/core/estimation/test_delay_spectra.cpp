// The delay's tapered difference spectra from a record's own DFT (delay_spectra.hpp) against
// the time-domain definition computed here step by step (differences, least-squares line,
// zero pad, taper) and a direct DFT sum, for odd and even lengths and with a large offset.
#include "../../../src/core/estimation/delay_spectra.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <random>
#include <vector>

namespace {

namespace detail = magnetometer_insitu_calibration::detail;

/// X(j) = sum_t x_t e^{-2 pi i j t / N}, summed directly.
std::complex<double> direct_dft(const std::vector<double>& x, long j) {
  const double n = static_cast<double>(x.size());
  std::complex<double> sum = 0.0;
  for (std::size_t t = 0; t < x.size(); ++t) {
    sum += x[t] * std::polar(1.0, -2.0 * M_PI * static_cast<double>(j) * static_cast<double>(t) / n);
  }
  return sum;
}

/// The series the delay transforms, built in the time domain: N - 1 differences, minus their
/// least-squares line, one zero appended, times 0.5 - 0.5 cos(2 pi (i + 1/2) / N).
std::vector<double> tapered_differences(const std::vector<double>& x) {
  const std::size_t n = x.size(), m = n - 1;
  std::vector<double> d(n, 0.0);
  double mean = 0.0;
  for (std::size_t i = 0; i < m; ++i) mean += (d[i] = x[i + 1] - x[i]);
  mean /= static_cast<double>(m);
  const double centre = 0.5 * static_cast<double>(m - 1);
  double num = 0.0, den = 0.0;
  for (std::size_t i = 0; i < m; ++i) {
    const double t = static_cast<double>(i) - centre;
    num += t * (d[i] - mean);
    den += t * t;
  }
  for (std::size_t i = 0; i < m; ++i) d[i] -= mean + num / den * (static_cast<double>(i) - centre);
  for (std::size_t i = 0; i < n; ++i) {
    d[i] *= 0.5 - 0.5 * std::cos(2.0 * M_PI * (static_cast<double>(i) + 0.5) / static_cast<double>(n));
  }
  return d;
}

void check_length(std::size_t n, double offset) {
  std::mt19937_64 rng(n);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> x(n);
  double walk = 0.0;
  for (std::size_t i = 0; i < n; ++i) {  // red (random walk) plus white plus a slope, nT
    walk += normal(rng);
    x[i] = offset + walk + 0.3 * normal(rng) + 0.01 * static_cast<double>(i);
  }
  const long j_first = 2, j_last = static_cast<long>(n / 2) - 1;
  std::vector<std::complex<double>> bins;
  for (long j = j_first - 1; j <= j_last + 1; ++j) bins.push_back(direct_dft(x, j));
  detail::ColumnEnds ends = detail::column_ends(Eigen::Map<const Eigen::VectorXd>(x.data(), static_cast<Eigen::Index>(n)));
  std::vector<std::complex<double>> fast(static_cast<std::size_t>(j_last - j_first + 1));
  detail::DifferenceKernel kernel;
  kernel.prepare(n, j_first, j_last);
  detail::tapered_difference_spectrum(bins.data(), ends, kernel, fast.data());
  const std::vector<double> q = tapered_differences(x);
  double scale = 0.0;
  for (double v : q) scale += std::abs(v);
  for (long j = j_first; j <= j_last; ++j) {
    const std::complex<double> expected = direct_dft(q, j);
    const std::complex<double> got = fast[static_cast<std::size_t>(j - j_first)];
    // Direct sums of N terms: agreement to rounding relative to sum |q_i| (and to the offset's).
    EXPECT_LT(std::abs(got - expected), 1e-11 * (scale + std::abs(offset) * static_cast<double>(n)))
        << "N " << n << " j " << j << " expected " << expected << " got " << got;
  }
}

}  // namespace

TEST(DelaySpectra, FrequencyDomainStepsEqualTheTimeDomainSeries) {
  check_length(257, 0.0);
  check_length(300, 0.0);
  check_length(1024, 0.0);
}

TEST(DelaySpectra, AConstantOffsetChangesNothing) { check_length(500, 20000.0); }
