// Windowed-sinc interpolation of a regular record (preprocessing/band_limited_interpolation.hpp)
// against known truth: sinusoids between their samples, a constant, missing rows, and the noise
// it passes (a harmonic sum on the samples; white noise's variance against a simulated record).
#include "magnetometer_insitu_calibration/preprocessing/band_limited_interpolation.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>

namespace mic = magnetometer_insitu_calibration;

namespace {

/// cos(2 pi f t), sin and 0 on a 1 s grid from t = 0, n samples.
mic::Readings sinusoid(double f_hz, int n) {
  mic::Readings r(n, 3);
  for (int i = 0; i < n; ++i) r.row(i) << std::cos(2.0 * M_PI * f_hz * i), std::sin(2.0 * M_PI * f_hz * i), 0.0;
  return r;
}

}  // namespace

TEST(BandLimitedInterpolation, PassesSinusoidsUpTo0_3HzBetweenTheSamples) {
  // Amplitude and phase at 0.37 s and 15.5 s past a sample, away from the record's ends.
  for (const double f : {0.001, 0.01, 0.1, 0.3}) {
    const mic::Readings r = sinusoid(f, 400);
    const std::vector<double> at = {100.37, 215.5, 300.0};
    const mic::Readings v = mic::interpolate_regular(r, 0.0, 1.0, at);
    for (std::size_t k = 0; k < at.size(); ++k) {
      EXPECT_NEAR(v(static_cast<Eigen::Index>(k), 0), std::cos(2.0 * M_PI * f * at[k]), 2e-3) << f << " Hz at " << at[k];
      EXPECT_NEAR(v(static_cast<Eigen::Index>(k), 1), std::sin(2.0 * M_PI * f * at[k]), 2e-3) << f << " Hz at " << at[k];
    }
  }
  // A straight line would lose 4.6 % at 0.1 Hz 0.37 s past a sample: this one 0.02 %.
  const mic::Readings v = mic::interpolate_regular(sinusoid(0.1, 400), 0.0, 1.0, {200.37});
  EXPECT_NEAR(std::hypot(v(0, 0), v(0, 1)), 1.0, 5e-4);
}

TEST(BandLimitedInterpolation, KeepsSamplesAndConstantsAndSaysWhereItCannot) {
  mic::Readings r = mic::Readings::Constant(100, 3, 48000.0);
  r(20, 1) = 7.0;
  const mic::Readings v = mic::interpolate_regular(r, 1000.0, 2.0, {1040.0, 1001.0, 999.0, 1198.0, 1198.5});
  EXPECT_DOUBLE_EQ(v(0, 1), 7.0) << "on a sample: the sample";
  EXPECT_NEAR(v(1, 0), 48000.0, 1e-9) << "a constant passes unchanged, also at the record's first samples";
  EXPECT_TRUE(std::isnan(v(2, 0))) << "before the record";
  EXPECT_NEAR(v(3, 2), 48000.0, 1e-9) << "the last sample";
  EXPECT_TRUE(std::isnan(v(4, 0))) << "after the record";
  r(30, 0) = std::numeric_limits<double>::quiet_NaN();
  const mic::Readings gap = mic::interpolate_regular(r, 1000.0, 2.0, {1061.0, 1061.0 + 2.0 * 2 * mic::kLanczosHalfWidth});
  EXPECT_TRUE(std::isnan(gap(0, 0))) << "a weight on a missing row";
  EXPECT_NEAR(gap(0, 2), 48000.0, 1e-9) << "the other columns";
  EXPECT_NEAR(gap(1, 0), 48000.0, 1e-9) << "beyond the kernel's reach";
  EXPECT_THROW(mic::interpolate_regular(r, 0.0, 0.0, {1.0}), std::invalid_argument);
  EXPECT_THROW(mic::lanczos_weights(0.5, 0), std::invalid_argument);
  const std::vector<double> w = mic::lanczos_weights(0.37, 4);
  EXPECT_NEAR(std::accumulate(w.begin(), w.end(), 0.0), 1.0, 1e-12);
}

TEST(BandLimitedInterpolation, TheNoiseItPasses) {
  // On the samples themselves nothing is filtered: white passes whole, and 1/f folds from m / 30 s,
  // m = 1..14 (below 0.5 Hz), as the harmonic sum H_14.
  std::vector<double> on_samples;
  for (int k = 0; k < 100; ++k) on_samples.push_back(30.0 * k);
  const mic::InterpolatedNoise exact = mic::interpolated_noise(0.0, 1.0, on_samples, 30.0);
  double h14 = 0.0;
  for (int m = 1; m <= 14; ++m) h14 += 1.0 / m;
  EXPECT_NEAR(exact.white_variance, 1.0, 1e-12);
  EXPECT_NEAR(exact.pink_alias, h14, 1e-9);
  // Between them, white noise's variance at the points is the weights' sum of squares: against
  // the variance of 20 000 interpolated points of a simulated white record.
  std::vector<double> between;
  for (int k = 0; k < 20000; ++k) between.push_back(40.0 + 30.0 * k + 0.37);
  const mic::InterpolatedNoise passed = mic::interpolated_noise(0.0, 1.0, between, 30.0);
  std::mt19937_64 engine(5);
  std::normal_distribution<double> normal;
  mic::Readings white = mic::Readings::Zero(30 * 20000 + 100, 3);
  for (Eigen::Index i = 0; i < white.rows(); ++i) white(i, 0) = normal(engine);
  const mic::Readings v = mic::interpolate_regular(white, 0.0, 1.0, between);
  const double variance = v.col(0).squaredNorm() / static_cast<double>(v.rows());
  EXPECT_NEAR(variance, passed.white_variance, 4.0 * passed.white_variance * std::sqrt(2.0 / 20000.0));
  EXPECT_LT(passed.white_variance, 1.0) << "between the samples a windowed sinc averages";
  EXPECT_LT(passed.pink_alias, h14) << "and attenuates near 0.5 Hz";
  EXPECT_GT(passed.pink_alias, 0.9 * h14);
}
