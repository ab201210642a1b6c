// The reference's noise from the pair above the band (estimation/two_instrument_noise.hpp),
// against the simulated noise of two instruments of different noise.
#include "magnetometer_insitu_calibration/estimation/two_instrument_noise.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "magnetometer_insitu_calibration/simulation/unmodelled_disturbances.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace mic = magnetometer_insitu_calibration;

namespace {

/// Two days at 1 Hz of the simulator's quiet station: reference white 10 pT + 1/f 5 pT/sqrt(Hz)
/// at 1 Hz, test white 30 pT and no 1/f noise, so that a method giving the pair's sum or the
/// test's noise is told from one giving the reference's.
mic::SimulationSettings two_days(std::uint64_t seed) {
  mic::SimulationSettings s;
  s.seed = seed;
  s.duration_s = 2.0 * 86400.0;
  s.reference_white_nT = 0.01;
  s.reference_pink_nT_per_sqrt_hz = 0.005;
  s.test_white_nT = 0.03;
  s.test_pink_nT_per_sqrt_hz = 0.0;
  return s;
}

double reference_psd(double f) { return 2.0 * 0.01 * 0.01 * 1.0 + 0.005 * 0.005 / f; }  // nT^2/Hz at f
double test_psd() { return 2.0 * 0.03 * 0.03 * 1.0; }

/// Standard deviation of a bin's estimate relative to the truth, from the model: per harmonic the
/// estimate's term is z = Re(conj(F + a) (a - b)), F the field (power P), a and b the reference's
/// and the test's noise (N_r, N_t), independent; the field cancels in the mean but not in the
/// scatter: Var z = P (N_r + N_t) / 2 + N_r^2 + N_r N_t / 2. Over the bin's M harmonics, Hann-
/// tapered neighbours correlated: M / (35/18) independent ones.
double relative_sd(const mic::TwoInstrumentNoise& noise, std::size_t k, int c, double truth) {
  const double p = noise.coherent_psd[k](c), t = test_psd();
  const double var_z = 0.5 * p * (truth + t) + truth * truth + 0.5 * truth * t;
  return std::sqrt(var_z * (35.0 / 18.0) / noise.harmonics[k]) / truth;
}

}  // namespace

TEST(TwoInstrumentNoise, RecoversTheReferenceNoiseAboveTheBandWithoutTheField) {
  const mic::SimulationSettings s = two_days(41);
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  const mic::TwoInstrumentNoise noise = mic::two_instrument_noise(pair.reference.values_nT, pair.test.values_nT, 1.0,
                                                                  pair.n_true, mic::RelativeTransfer{}, 0.03, 0.25, 6);
  ASSERT_EQ(noise.reference_psd.size(), 6u);
  double chi2 = 0.0;
  for (std::size_t k = 0; k < 6; ++k) {
    const double f = std::sqrt(noise.bin_low_hz[k] * noise.bin_high_hz[k]);
    for (int c = 0; c < 3; ++c) {
      // Within 4 of its standard deviations.
      const double sd = relative_sd(noise, k, c, reference_psd(f));
      const double z = (noise.reference_psd[k](c) / reference_psd(f) - 1.0) / sd;
      EXPECT_LT(std::abs(z), 4.0) << "bin " << k << " axis " << c << ", sd " << sd;
      chi2 += z * z;
    }
  }
  std::printf("chi2 / dof of the 18 values: %.3f\n", chi2 / 18.0);
  EXPECT_LT(chi2 / 18.0, 2.0);  // and the scatter is the one stated
  // The subtraction matters: the field's part of the reference's PSD in the lowest bin is many
  // times the noise there (the test's own noise, 9x the reference's white level, is not in it).
  EXPECT_GT(noise.coherent_psd[0].minCoeff() / reference_psd(0.036), 3.0);
}

TEST(TwoInstrumentNoise, StatesTheScatterOfItsEstimate) {
  // reference_psd_sd against (a) the model formula above, per bin, and (b) the estimates' own
  // scatter about the truth over 20 independent 6-hour records (360 values).
  double z2 = 0.0;
  int values = 0;
  for (std::uint64_t seed = 300; seed < 320; ++seed) {
    mic::SimulationSettings s = two_days(seed);
    s.duration_s = 6.0 * 3600.0;
    const mic::SimulatedPair pair = mic::simulate_pair(s);
    const mic::TwoInstrumentNoise noise = mic::two_instrument_noise(
        pair.reference.values_nT, pair.test.values_nT, 1.0, pair.n_true, mic::RelativeTransfer{}, 0.03, 0.25, 6);
    ASSERT_EQ(noise.reference_psd_sd.size(), 6u);
    for (std::size_t k = 0; k < 6; ++k) {
      const double f = std::sqrt(noise.bin_low_hz[k] * noise.bin_high_hz[k]);
      for (int c = 0; c < 3; ++c) {
        const double stated = noise.reference_psd_sd[k](c) / reference_psd(f);
        EXPECT_NEAR(stated / relative_sd(noise, k, c, reference_psd(f)), 1.0, 0.3) << "seed " << seed << " bin " << k;
        const double z = (noise.reference_psd[k](c) / reference_psd(f) - 1.0) / stated;
        z2 += z * z;
        ++values;
      }
    }
  }
  const double rms = std::sqrt(z2 / values);
  std::printf("rms (estimate - truth) / stated sd over %d values: %.3f\n", values, rms);
  EXPECT_GT(rms, 0.85);
  EXPECT_LT(rms, 1.15);
}

TEST(TwoInstrumentNoise, ADelayedTestNeedsItsDelayInTheTransfer) {
  const mic::SimulationSettings s = two_days(42);
  mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::apply_test_response(pair.test.values_nT, 1.0, 0.0, 2.0);  // the test 2 s late
  mic::RelativeTransfer late;
  late.delay_s = 2.0;
  const mic::TwoInstrumentNoise with = mic::two_instrument_noise(pair.reference.values_nT, pair.test.values_nT, 1.0,
                                                                 pair.n_true, late, 0.03, 0.25, 6);
  const mic::TwoInstrumentNoise without = mic::two_instrument_noise(pair.reference.values_nT, pair.test.values_nT, 1.0,
                                                                    pair.n_true, mic::RelativeTransfer{}, 0.03, 0.25, 6);
  const double truth = reference_psd(std::sqrt(with.bin_low_hz[0] * with.bin_high_hz[0]));
  for (int c = 0; c < 3; ++c) {
    const double sd = relative_sd(with, 0, c, truth);
    EXPECT_LT(std::abs(with.reference_psd[0](c) / truth - 1.0), 4.0 * sd) << c;
    // Without it, 1 - cos(2 pi f 2 s) of the field's part (0.10 at the bin's middle, 0.036 Hz;
    // the field is tens of times the noise there) is taken for noise: the same records, so the
    // difference is that bias, not scatter.
    const double f = std::sqrt(with.bin_low_hz[0] * with.bin_high_hz[0]);
    const double bias = (1.0 - std::cos(2.0 * M_PI * f * 2.0)) * with.coherent_psd[0](c) / truth;
    EXPECT_NEAR((without.reference_psd[0](c) - with.reference_psd[0](c)) / truth, bias, 0.3 * bias) << c;
  }
}

TEST(TwoInstrumentNoise, BadInputIsNamed) {
  const mic::Readings r = mic::Readings::Zero(4096, 3), t = mic::Readings::Zero(4000, 3);
  const auto where = [](auto&& call) {
    try {
      call();
    } catch (const mic::InputError& e) {
      return e.where();
    }
    return std::string("no error");
  };
  const Eigen::Matrix3d n = Eigen::Matrix3d::Identity();
  EXPECT_EQ(where([&] { mic::two_instrument_noise(r, t, 1.0, n, {}, 0.03, 0.25, 6); }), "two_instrument_noise");
  EXPECT_EQ(where([&] { mic::two_instrument_noise(r, r, 1.0, n, {}, 0.03, 0.6, 6); }), "two_instrument_noise");
  EXPECT_EQ(where([&] { mic::two_instrument_noise(r, r, 1.0, Eigen::Matrix3d::Zero(), {}, 0.03, 0.25, 6); }),
            "two_instrument_noise");
  // 400 s: the lowest of 6 bins over 0.03-0.25 Hz (0.030-0.042 Hz) holds 5 harmonics, fewer than 8.
  const mic::Readings short_record = mic::Readings::Zero(400, 3);
  EXPECT_EQ(where([&] { mic::two_instrument_noise(short_record, short_record, 1.0, n, {}, 0.03, 0.25, 6); }),
            "two_instrument_noise");
}

TEST(TwoInstrumentNoise, ATestRollingOffAboveTheBandIsToldFromReferenceNoiseByItsPhase) {
  // The test behind a 0.5 Hz one-pole and 0.2 s late: its gain falls to 0.89 at the top bin
  // (0.18-0.25 Hz), which the gain alone would take for reference noise. The response model's
  // delay at low frequency holds the corner's lag: 0.2 + 1 / (2 pi 0.5) = 0.518 s.
  const mic::SimulationSettings s = two_days(43);
  mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::apply_test_response(pair.test.values_nT, 1.0, 0.5, 0.2);
  const double start_delay = 0.2 + 1.0 / (2.0 * M_PI * 0.5);
  const mic::PhaseTransferFit fit = mic::fit_transfer_from_phase(pair.reference.values_nT, pair.test.values_nT, 1.0,
                                                                 pair.n_true, start_delay, 0.03, 0.25, 6);
  ASSERT_TRUE(fit.fitted);
  ASSERT_TRUE(fit.any_corner()) << "curvature chi2 " << fit.curvature_chi2;
  std::printf("%s\n", fit.text.c_str());
  // 1 / fc = 2 s, within 3 of its standard errors and 15 %.
  EXPECT_NEAR(fit.inverse_corner_s, 2.0, std::min(0.3, 3.0 * fit.inverse_corner_se_s)) << fit.text;
  for (int c = 0; c < 3; ++c) EXPECT_EQ(fit.transfer.corner_hz(c), 1.0 / fit.inverse_corner_s);
  EXPECT_NEAR(fit.transfer.delay_s, 0.2, 0.05) << fit.text;
  EXPECT_LT(fit.chi2_per_dof, 3.0);
  mic::RelativeTransfer delay_only;
  delay_only.delay_s = start_delay;
  const mic::TwoInstrumentNoise with = mic::two_instrument_noise(pair.reference.values_nT, pair.test.values_nT, 1.0,
                                                                 pair.n_true, fit.transfer, 0.03, 0.25, 6);
  const mic::TwoInstrumentNoise without = mic::two_instrument_noise(pair.reference.values_nT, pair.test.values_nT, 1.0,
                                                                    pair.n_true, delay_only, 0.03, 0.25, 6);
  for (std::size_t k = 0; k < 6; ++k) {
    const double f = std::sqrt(with.bin_low_hz[k] * with.bin_high_hz[k]);
    for (int c = 0; c < 3; ++c) {
      const double truth = reference_psd(f), sd = relative_sd(with, k, c, truth);
      EXPECT_LT(std::abs(with.reference_psd[k](c) / truth - 1.0), 4.0 * sd) << "bin " << k << " axis " << c;
    }
  }
  // With the delay alone the top bin's estimate holds 1 - |H| = 1 - 1 / sqrt(1 + (f / 0.5)^2) of
  // the field's part (0.07 at the bin's middle; the field there 2-20 times the noise, the
  // weak vertical least): the same records, so the difference is that bias.
  const std::size_t top = 5;
  const double f = std::sqrt(with.bin_low_hz[top] * with.bin_high_hz[top]);
  const double truth = reference_psd(f);
  for (int c = 0; c < 3; ++c) {
    const double bias = (1.0 - 1.0 / std::sqrt(1.0 + f * f / 0.25)) * with.coherent_psd[top](c) / truth;
    EXPECT_GT(bias, 0.1) << c;  // of the true noise
    std::printf("axis %d: bias with the delay alone %.2f of the reference's noise\n", c, bias);
    EXPECT_NEAR((without.reference_psd[top](c) - with.reference_psd[top](c)) / truth, bias, 0.3 * bias) << c;
  }
}

TEST(TwoInstrumentNoise, AnUnfilteredTestShowsNoRollOff) {
  // The same station with the test only 2 s late: no corner counts, the transfer is the delay.
  const mic::SimulationSettings s = two_days(44);
  mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::apply_test_response(pair.test.values_nT, 1.0, 0.0, 2.0);
  const mic::PhaseTransferFit fit =
      mic::fit_transfer_from_phase(pair.reference.values_nT, pair.test.values_nT, 1.0, pair.n_true, 2.0, 0.03, 0.25, 6);
  ASSERT_TRUE(fit.fitted);
  EXPECT_FALSE(fit.any_corner()) << fit.text;
  EXPECT_LT(fit.curvature_chi2, mic::kPhaseCornerChi2);
  EXPECT_EQ(fit.transfer.delay_s, 2.0);
  EXPECT_TRUE(fit.transfer.corner_hz.array().isInf().all());
  EXPECT_TRUE(fit.text.empty());
  EXPECT_LT(fit.chi2_per_dof, 3.0);
}
