// The 95 % intervals of n's parameters take Student's t with the cells n's covariance rests on:
// the quantile against printed tables and against the F tail it inverts; a standard error
// estimated from nu chi2 cells covers 95 % with it and less with the normal 1.96 (sampled
// independently of the code under test); decompose() scales the delta-method half-widths by it;
// both estimators pass their windows' cells to it.
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "magnetometer_insitu_calibration/estimation/robust/robust_estimator.hpp"
#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"
#include "simulated_hour.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace mic = magnetometer_insitu_calibration;

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}

TEST(IntervalQuantile, StudentQuantileMatchesTables) {
  // Two-sided 5 % points of Student's t (any statistics table, to the 4 decimals printed).
  const double table[][2] = {{1, 12.7062}, {2, 4.3027}, {5, 2.5706}, {10, 2.2281},
                             {24, 2.0639}, {30, 2.0423}, {120, 1.9799}};
  for (const auto& row : table) EXPECT_NEAR(mic::student_t_two_sided_quantile(0.05, row[0]), row[1], 1e-4) << row[0];
  EXPECT_NEAR(mic::student_t_two_sided_quantile(0.01, 10.0), 3.1693, 1e-4);
  EXPECT_NEAR(mic::student_t_two_sided_quantile(0.05, kInf), 1.959964, 1e-6);
  EXPECT_NEAR(mic::student_t_two_sided_quantile(0.05, 1e9), 1.959964, 1e-6);
  // A fractional nu (a Satterthwaite count) lies between its neighbours, and inverts the F tail.
  const double q = mic::student_t_two_sided_quantile(0.05, 9.37);
  EXPECT_LT(q, mic::student_t_two_sided_quantile(0.05, 9.0));
  EXPECT_GT(q, mic::student_t_two_sided_quantile(0.05, 10.0));
  EXPECT_NEAR(mic::f_tail_probability(q * q, 1.0, 9.37), 0.05, 1e-12);
  for (double bad_nu : {0.0, -3.0, std::nan("")}) EXPECT_TRUE(std::isnan(mic::student_t_two_sided_quantile(0.05, bad_nu)));
  for (double bad_tail : {0.0, 1.0, -0.1}) EXPECT_TRUE(std::isnan(mic::student_t_two_sided_quantile(bad_tail, 10.0)));
}

TEST(IntervalQuantile, EstimatedStandardErrorCoversWithTheStudentQuantile) {
  // An estimate x ~ N(0, 1) with its variance estimated from nu cells, s^2 ~ chi2_nu / nu: the
  // interval x +- q s covers 0 in 95 % of draws with q = t(nu), not with 1.96 (92.2 % at nu = 10).
  std::mt19937_64 rng(20261126);
  std::normal_distribution<double> normal;
  for (double nu : {10.0, 24.0}) {
    std::chi_squared_distribution<double> chi2(nu);
    const double q = mic::student_t_two_sided_quantile(0.05, nu);
    const int draws = 40000;
    int covered_t = 0, covered_normal = 0;
    for (int d = 0; d < draws; ++d) {
      const double x = normal(rng), s = std::sqrt(chi2(rng) / nu);
      covered_t += std::abs(x) <= q * s;
      covered_normal += std::abs(x) <= 1.959964 * s;
    }
    // Binomial sd at 40000 draws: 0.0011; the bounds are 3 sd.
    EXPECT_NEAR(covered_t / static_cast<double>(draws), 0.95, 0.0035) << nu;
    const double normal_share = covered_normal / static_cast<double>(draws);
    EXPECT_NEAR(normal_share, 1.0 - mic::f_tail_probability(1.959964 * 1.959964, 1.0, nu), 0.0035) << nu;
    EXPECT_LT(normal_share, 0.95 - 0.005) << nu;
  }
}

TEST(IntervalQuantile, DecomposeScalesTheDeltaMethodHalfWidths) {
  Eigen::Matrix3d n;
  n << 1.002, 0.001, -0.003, 0.0005, 0.998, 0.002, 0.004, -0.001, 1.001;
  const mic::Matrix9d cov = mic::Matrix9d::Identity() * 4e-8;
  const mic::CalibrationParameters known = mic::decompose(n, cov);  // covariance taken as known
  EXPECT_TRUE(std::isinf(known.interval_dof));
  EXPECT_NEAR(known.interval_quantile, 1.959964, 1e-6);
  const mic::CalibrationParameters few = mic::decompose(n, cov, 12.5);
  EXPECT_DOUBLE_EQ(few.interval_dof, 12.5);
  const double q = mic::student_t_two_sided_quantile(0.05, 12.5);
  EXPECT_DOUBLE_EQ(few.interval_quantile, q);
  const double ratio = q / known.interval_quantile;
  EXPECT_GT(ratio, 1.08);  // t(12.5) = 2.17
  for (int l = 0; l < 3; ++l) {
    EXPECT_DOUBLE_EQ(few.scale_ratio(l), known.scale_ratio(l));
    EXPECT_NEAR(few.scale_ratio_ci95(l), ratio * known.scale_ratio_ci95(l), 1e-12 * known.scale_ratio_ci95(l));
    EXPECT_NEAR(few.nonorthogonality_ci95_deg(l), ratio * known.nonorthogonality_ci95_deg(l),
                1e-12 * known.nonorthogonality_ci95_deg(l));
    EXPECT_NEAR(few.misalignment_ci95_deg(l), ratio * known.misalignment_ci95_deg(l),
                1e-12 * known.misalignment_ci95_deg(l));
  }
}

TEST(IntervalQuantile, BothEstimatorsUseTheirWindowsCells) {
  // A simulated hour: covariances from 18-36 cells, so the half-widths are t(cells) standard
  // errors, 2.03-2.11, and a parameter's standard error is the same either way.
  const mic::SimulatedPair hour = mic::test::simulated_hour(71);
  mic::WindowEstimator plain(mic::test::plain_eq2_settings()), robust(mic::EstimatorSettings{});
  for (mic::WindowEstimator* estimator : {&plain, &robust}) {
    const mic::WindowEstimate e = estimator->estimate(hour.reference.values_nT, hour.test.values_nT, 1.0);
    ASSERT_EQ(e.quality, mic::Quality::kOk) << e.method;
    const mic::CalibrationParameters& p = e.parameters;
    EXPECT_DOUBLE_EQ(p.interval_dof, e.covariance_dof) << e.method;
    EXPECT_DOUBLE_EQ(p.interval_quantile, mic::student_t_two_sided_quantile(0.05, e.covariance_dof)) << e.method;
    EXPECT_GT(p.interval_quantile, 2.03) << e.method;
    EXPECT_LT(p.interval_quantile, 2.11) << e.method;
    const mic::CalibrationParameters normal = mic::decompose(e.n, e.n_covariance);
    for (int l = 0; l < 3; ++l) {
      EXPECT_NEAR(p.scale_ratio_ci95(l) / p.interval_quantile, normal.scale_ratio_ci95(l) / normal.interval_quantile,
                  1e-9 * normal.scale_ratio_ci95(l))
          << e.method;
    }
  }
}
