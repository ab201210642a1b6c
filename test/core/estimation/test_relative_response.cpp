// relative_response against a known filter: a test instrument behind a 1-pole low-pass at 0.03 Hz
// and a 2 s delay (reference flat), and against a flat pair (gain 1, phase 0).
#include "magnetometer_insitu_calibration/estimation/relative_response.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "test_constants.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <complex>
#include <random>

namespace mic = magnetometer_insitu_calibration;

namespace {

using magnetometer_insitu_calibration::test::kPi;

struct ResponsePair {
  mic::Readings reference, test;
  mic::Readings clean;  ///< the field without instrument noise, nT
  Eigen::Matrix3d n;
};

/// One day at 1 Hz: a random-walk field (f^-2 spectrum, 0.05 nT steps) plus 10 pT (or
/// reference_noise_nT) white noise in the reference; T = filter(R_clean n) + 30 pT white noise. The filter is y_k = a y_{k-1} +
/// (1 - a) x_{k - delay} (a = exp(-2 pi fc dt)), or none when fc = 0.
ResponsePair simulate(unsigned seed, double corner_hz, int delay_samples, std::size_t samples = 86400,
              double reference_noise_nT = 0.01) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> step(0.0, 0.05), ref_noise(0.0, reference_noise_nT), test_noise(0.0, 0.03);
  ResponsePair p;
  p.n << 1.002, 0.004, -0.003, -0.005, 0.997, 0.006, 0.002, -0.004, 1.004;
  mic::Readings clean(static_cast<Eigen::Index>(samples), 3);
  Eigen::RowVector3d level(20000.0, 1000.0, 45000.0);
  for (Eigen::Index i = 0; i < clean.rows(); ++i) {
    for (int c = 0; c < 3; ++c) level(c) += step(rng);
    clean.row(i) = level;
  }
  const mic::Readings ideal = clean * p.n;
  p.clean = clean;
  p.reference = clean;
  p.test = ideal;
  if (corner_hz > 0.0) {
    const double a = std::exp(-2.0 * kPi * corner_hz);
    Eigen::RowVector3d y = ideal.row(0);
    for (Eigen::Index i = 0; i < ideal.rows(); ++i) {
      const Eigen::Index src = std::max<Eigen::Index>(0, i - delay_samples);
      y = a * y + (1.0 - a) * ideal.row(src);
      p.test.row(i) = y;
    }
  }
  for (Eigen::Index i = 0; i < clean.rows(); ++i) {
    for (int c = 0; c < 3; ++c) {
      p.reference(i, c) += ref_noise(rng);
      p.test(i, c) += test_noise(rng);
    }
  }
  return p;
}

/// The digital filter's response at f (Hz, dt = 1 s).
std::complex<double> true_response(double f, double corner_hz, int delay_samples) {
  const double w = 2.0 * kPi * f;
  const double a = std::exp(-2.0 * kPi * corner_hz);
  const std::complex<double> z1 = std::exp(std::complex<double>(0.0, -w));
  return (1.0 - a) / (1.0 - a * z1) * std::exp(std::complex<double>(0.0, -w * delay_samples));
}

}  // namespace

TEST(RelativeResponse, FlatPairHasUnitGainAndZeroPhaseWithinIntervals) {
  const ResponsePair p = simulate(3, 0.0, 0);
  const auto bands = mic::relative_response(p.reference, p.test, p.n, 1.0);
  ASSERT_GE(bands.size(), 10u);
  int inside = 0, total = 0;
  for (const auto& b : bands) {
    EXPECT_GE(b.harmonics, 6u);
    EXPECT_GT(b.frequency_hz, b.low_hz);
    EXPECT_LT(b.frequency_hz, b.high_hz);
    for (int k = 0; k < 3; ++k) {
      inside += std::abs(b.gain(k) - 1.0) <= b.gain_ci95(k);
      inside += std::abs(b.phase_deg(k)) <= b.phase_ci95_deg(k);
      total += 2;
    }
  }
  EXPECT_GE(inside, static_cast<int>(0.85 * total)) << inside << " of " << total;
  const auto summary = mic::summarise_response(bands, 0.0002, 0.01);
  EXPECT_LT(summary.max_gain_departure, 0.01);
  EXPECT_LT(std::abs(summary.group_delay_s), 0.05);
}

// The 1-pole low-pass at 0.03 Hz with a 2 s delay: at 0.01 and 0.03 Hz the reported gain and phase
// match the true filter (evaluated at the band's reported frequency) within their intervals in
// 85-99 % of (seed, component, quantity) cases over 40 seeds; the intervals are narrow enough to
// tell the filter from a flat response (the test could fail either way).
TEST(RelativeResponse, LowPassAndDelayRecoveredWithinIntervals) {
  const double corner = 0.03;
  const int delay = 2;
  int inside = 0, total = 0;
  // MIC_RESPONSE_SEEDS=100 for the figure in docs/method.md; 40 in the test suite.
  const char* seeds_env = std::getenv("MIC_RESPONSE_SEEDS");
  const unsigned seeds = seeds_env != nullptr ? static_cast<unsigned>(std::atoi(seeds_env)) : 40u;
  for (unsigned seed = 100; seed < 100 + seeds; ++seed) {
    const ResponsePair p = simulate(seed, corner, delay);
    const auto bands = mic::relative_response(p.reference, p.test, p.n, 1.0);
    for (double f : {0.01, 0.03}) {
      const auto it = std::find_if(bands.begin(), bands.end(),
                                   [f](const mic::ResponseBand& b) { return b.low_hz <= f && f < b.high_hz; });
      ASSERT_NE(it, bands.end()) << f;
      const std::complex<double> truth = true_response(it->frequency_hz, corner, delay);
      for (int k = 0; k < 3; ++k) {
        const double true_gain = std::abs(truth), true_phase = std::arg(truth) * 180.0 / kPi;
        ASSERT_LT(it->gain_ci95(k), 0.25 * std::abs(1.0 - true_gain)) << "interval too wide to see the filter";
        inside += std::abs(it->gain(k) - true_gain) <= it->gain_ci95(k);
        inside += std::abs(it->phase_deg(k) - true_phase) <= it->phase_ci95_deg(k);
        total += 2;
      }
    }
  }
  const double share = static_cast<double>(inside) / total;
  EXPECT_GE(share, 0.85) << inside << " of " << total;
  EXPECT_LE(share, 0.99) << "intervals wider than the scatter";
  std::printf("low-pass 0.03 Hz + 2 s delay: %d of %d gain/phase values inside their 95 %% intervals (%.1f %%)\n",
              inside, total, 100.0 * share);
}

// A flat pair whose reference carries 30 pT of white noise: above 0.03 Hz, where the random-walk
// field is weak, that noise attenuates the gain (by 1-12 %: sigma_r^2 / (S_field + sigma_r^2));
// with the reference's noise given (a maker's figure, a three-cornered hat) the gain is 1 within
// its intervals again.
TEST(RelativeResponse, IdentifiedReferenceNoiseRemovesTheAttenuationOfTheGain) {
  const ResponsePair p = simulate(11, 0.0, 0, 86400, 0.03);
  mic::RelativeResponseSettings corrected;
  corrected.reference_noise.white_nT.setConstant(0.03);
  const auto plain = mic::relative_response(p.reference, p.test, p.n, 1.0);
  const auto fixed = mic::relative_response(p.reference, p.test, p.n, 1.0, corrected);
  ASSERT_EQ(plain.size(), fixed.size());
  int bands = 0, inside_plain = 0, inside_fixed = 0, total = 0;
  double z_plain = 0.0, z_fixed = 0.0;
  for (std::size_t i = 0; i < plain.size(); ++i) {
    if (plain[i].frequency_hz < 0.03) continue;
    ++bands;
    for (int k = 0; k < 3; ++k) {
      const double sd_plain = plain[i].gain_ci95(k) / 1.96, sd_fixed = fixed[i].gain_ci95(k) / 1.96;
      z_plain += (plain[i].gain(k) - 1.0) / sd_plain;
      z_fixed += (fixed[i].gain(k) - 1.0) / sd_fixed;
      inside_plain += std::abs(plain[i].gain(k) - 1.0) <= plain[i].gain_ci95(k);
      inside_fixed += std::abs(fixed[i].gain(k) - 1.0) <= fixed[i].gain_ci95(k);
      ++total;
    }
  }
  ASSERT_GE(bands, 4);
  std::printf("gain above 0.03 Hz, 30 pT reference: mean z %.2f uncorrected, %.2f corrected; inside %d / %d of %d\n",
              z_plain / total, z_fixed / total, inside_plain, inside_fixed, total);
  EXPECT_LT(z_plain / total, -3.0);                 // attenuated, by many of its own standard errors
  EXPECT_LT(std::abs(z_fixed / total), 1.0);        // unbiased
  EXPECT_GE(inside_fixed, static_cast<int>(0.8 * total));
}

// The same flat pair with 30 pT in the reference, and a remote observatory (the field through a
// mixing of its own, 20 % of its variations' variance its own random walk, 20 pT white noise):
// on the remote's instruments the gain above 0.03 Hz is 1 within its intervals without any
// model of the reference's noise, where the pair's own is attenuated.
TEST(RelativeResponse, RemoteInstrumentsRemoveTheAttenuationWithoutANoiseModel) {
  const ResponsePair p = simulate(11, 0.0, 0, 86400, 0.03);
  std::mt19937_64 rng(99);
  std::normal_distribution<double> step(0.0, 0.05 * std::sqrt(0.2)), noise(0.0, 0.02);
  Eigen::Matrix3d q;
  q << 0.9, 0.3, 0.1, -0.3, 0.95, 0.0, 0.05, 0.1, 0.7;
  mic::Readings own(p.clean.rows(), 3);
  Eigen::RowVector3d level = Eigen::RowVector3d::Zero();
  for (Eigen::Index i = 0; i < own.rows(); ++i) {
    for (int c = 0; c < 3; ++c) level(c) += step(rng);
    own.row(i) = level;
  }
  mic::Readings remote = (std::sqrt(0.8) * p.clean + own) * q;
  for (Eigen::Index i = 0; i < remote.rows(); ++i)
    for (int c = 0; c < 3; ++c) remote(i, c) += noise(rng);
  const auto plain = mic::relative_response(p.reference, p.test, p.n, 1.0);
  const auto on_remote = mic::relative_response(p.reference, p.test, p.n, 1.0, {}, &remote);
  ASSERT_EQ(plain.size(), on_remote.size());
  int inside = 0, total = 0;
  double z_plain = 0.0, z_remote = 0.0;
  for (std::size_t i = 0; i < plain.size(); ++i) {
    if (plain[i].frequency_hz < 0.03) continue;
    for (int k = 0; k < 3; ++k) {
      z_plain += (plain[i].gain(k) - 1.0) / (plain[i].gain_ci95(k) / 1.96);
      z_remote += (on_remote[i].gain(k) - 1.0) / (on_remote[i].gain_ci95(k) / 1.96);
      inside += std::abs(on_remote[i].gain(k) - 1.0) <= on_remote[i].gain_ci95(k);
      ++total;
    }
  }
  ASSERT_GE(total, 12);
  std::printf("gain above 0.03 Hz, 30 pT reference: mean z %.2f on the pair, %.2f on the remote; inside %d of %d\n",
              z_plain / total, z_remote / total, inside, total);
  EXPECT_LT(z_plain / total, -3.0);
  EXPECT_LT(std::abs(z_remote / total), 1.0);
  EXPECT_GE(inside, static_cast<int>(0.8 * total));
}

TEST(RelativeResponse, GroupDelayOfAPureDelay) {
  const ResponsePair p = simulate(7, 1e9, 3);  // a = 0: a pure 3-sample delay
  const auto bands = mic::relative_response(p.reference, p.test, p.n, 1.0);
  const auto summary = mic::summarise_response(bands, 0.0002, 0.05);
  ASSERT_GT(summary.bands, 3u);
  EXPECT_NEAR(summary.group_delay_s, 3.0, 0.05);
  EXPECT_LT(summary.max_gain_departure, 0.02);
}

TEST(RelativeResponse, ImpossibleSettingsAreRefused) {
  mic::RelativeResponseSettings s;
  s.low_hz = 0.0;
  EXPECT_THROW(s.validate(), mic::InputError);
  s = {};
  s.high_hz = s.low_hz;
  EXPECT_THROW(s.validate(), mic::InputError);
  s = {};
  s.bands_per_decade = 0;
  EXPECT_THROW(s.validate(), mic::InputError);
}
