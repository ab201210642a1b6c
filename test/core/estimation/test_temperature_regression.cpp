// Temperature terms (temperature_regression.hpp) on simulated hut records with known
// coefficients (simulation/hut_temperature.hpp): the truth comes from the simulation settings,
// the apparent coefficient a_l = c_l + s_l F_l from the test's mean reading F_l.
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/estimation/temperature_regression.hpp"
#include "magnetometer_insitu_calibration/simulation/hut_temperature.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include "hut_fixture.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

namespace mic = magnetometer_insitu_calibration;

namespace {

using mic::test::HutPair;

HutPair simulate_hut(std::uint64_t seed, double days = 2.0) { return mic::test::hut_pair(seed, days * 86400.0); }

}  // namespace

TEST(TemperatureRegression, RecoversTheHutCoefficientsWithinTheirIntervals) {
  const HutPair h = simulate_hut(3);
  const mic::Readings& r = h.pair.reference.values_nT;
  const mic::Readings& t = h.pair.test.values_nT;
  mic::FdWlseEstimator plain;
  const mic::WindowEstimate without = plain.estimate(r, t, 1.0);
  const mic::TemperatureFit fit = mic::fit_temperature(r, t, h.reading_C(), 1.0, without.n, mic::TemperatureBand{});
  ASSERT_TRUE(fit.fitted) << fit.text;
  EXPECT_NEAR(fit.reference_C, h.reading_C().mean(), 1e-12);
  for (int l = 0; l < 3; ++l) {
    const double mean_test = t.col(l).mean();
    const double s_true = 1e-6 * h.hut.scale_ppm_per_C(l);
    const double apparent_true = h.hut.offset_nT_per_C(l) + s_true * mean_test;
    std::printf("[ result ] component %d: apparent %.4f +- %.4f nT/degC (true %.4f); offset %.3f +- %.3f (true %.3f); "
                "scale %.1f +- %.1f ppm/degC (true %.1f)\n",
                l, fit.apparent_nT_per_C(l), fit.apparent_ci95_nT_per_C(l), apparent_true, fit.offset_nT_per_C(l),
                fit.offset_ci95_nT_per_C(l), h.hut.offset_nT_per_C(l), fit.scale_ppm_per_C(l), fit.scale_ci95_ppm_per_C(l),
                h.hut.scale_ppm_per_C(l));
    // One seed: inside 1.5 x the 95 % half-width (the Monte Carlo program measures coverage).
    EXPECT_LT(std::abs(fit.apparent_nT_per_C(l) - apparent_true), 1.5 * fit.apparent_ci95_nT_per_C(l));
    EXPECT_LT(std::abs(fit.offset_nT_per_C(l) - h.hut.offset_nT_per_C(l)), 1.5 * fit.offset_ci95_nT_per_C(l));
    EXPECT_LT(std::abs(fit.scale_ppm_per_C(l) - h.hut.scale_ppm_per_C(l)), 1.5 * fit.scale_ci95_ppm_per_C(l));
    // The apparent coefficient is well determined: a few hundredths of nT/degC at most.
    EXPECT_LT(fit.apparent_ci95_nT_per_C(l), 0.05);
  }
  // Removing the terms and estimating again: n within 3 se of the truth, residual smaller.
  const mic::Readings corrected = mic::remove_temperature_terms(r, t, h.reading_C(), without.n, fit);
  const mic::WindowEstimate with = plain.estimate(r, corrected, 1.0);
  const Eigen::Matrix3d se = with.n_stderr();
  for (int k = 0; k < 9; ++k) {
    EXPECT_LT(std::abs(with.n(k / 3, k % 3) - h.pair.n_true(k / 3, k % 3)), 3.0 * se(k / 3, k % 3)) << "entry " << k;
  }
  for (int l = 0; l < 3; ++l) EXPECT_LT(with.residual_rms_nT(l), without.residual_rms_nT(l)) << "component " << l;
}

TEST(TemperatureRegression, StatesWhyItDoesNotFit) {
  const HutPair h = simulate_hut(4, 0.5);
  const mic::Readings& r = h.pair.reference.values_nT;
  const mic::Readings& t = h.pair.test.values_nT;
  Eigen::VectorXd constant = Eigen::VectorXd::Constant(r.rows(), 21.0);
  mic::TemperatureFit fit = mic::fit_temperature(r, t, constant, 1.0, Eigen::Matrix3d::Identity(), mic::TemperatureBand{});
  EXPECT_FALSE(fit.fitted);
  EXPECT_NE(fit.text.find("temperature range 0 degC below 0.05 degC"), std::string::npos) << fit.text;

  Eigen::VectorXd holes = h.reading_C();
  holes(100) = std::nan("");
  fit = mic::fit_temperature(r, t, holes, 1.0, Eigen::Matrix3d::Identity(), mic::TemperatureBand{});
  EXPECT_FALSE(fit.fitted);
  EXPECT_NE(fit.text.find("temperature missing (NaN)"), std::string::npos) << fit.text;
  // Nothing fitted: nothing removed.
  EXPECT_TRUE(mic::remove_temperature_terms(r, t, holes, Eigen::Matrix3d::Identity(), fit) == t);
  EXPECT_THROW(mic::fit_temperature(r, t, holes.head(10), 1.0, Eigen::Matrix3d::Identity(), mic::TemperatureBand{}),
               std::invalid_argument);
}
