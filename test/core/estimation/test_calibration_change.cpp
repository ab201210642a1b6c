// Calibration change: unchanged between two days of one instrument, changed after a 0.5 % scale
// step, inconclusive for a flagged window; the chi^2 and F tails against tables and closed forms;
// one-hour windows' covariances referred to Hotelling's T^2 with their cells; below 36 cells the
// parameters decide one by one (Welch's t), worked by hand.
#include "magnetometer_insitu_calibration/estimation/calibration_change.hpp"
#include "magnetometer_insitu_calibration/estimation/calibration_matrix.hpp"
#include "magnetometer_insitu_calibration/estimation/robust/robust_estimator.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "simulated_hour.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace mic = magnetometer_insitu_calibration;

TEST(CalibrationChange, ChiSquareTailMatchesTables) {
  EXPECT_NEAR(mic::chi2_tail_probability(16.919, 9), 0.05, 2e-4);
  EXPECT_NEAR(mic::chi2_tail_probability(27.877, 9), 0.001, 2e-5);
  EXPECT_NEAR(mic::chi2_tail_probability(3.841, 1), 0.05, 2e-4);
  EXPECT_NEAR(mic::chi2_tail_probability(2.088, 9), 0.99, 2e-4);
  EXPECT_DOUBLE_EQ(mic::chi2_tail_probability(0.0, 9), 1.0);
}

TEST(CalibrationChange, FTailMatchesClosedFormsAndTables) {
  // d1 = 2: P(F > f) = (1 + 2 f / d2)^(-d2 / 2). d1 = d2 = 1 (F = t^2, Cauchy t): 1 - (2 / pi) atan(sqrt(f)).
  for (double f : {0.1, 1.0, 3.0, 20.0}) {
    for (double d2 : {1.0, 5.0, 28.0, 300.0}) {
      EXPECT_NEAR(mic::f_tail_probability(f, 2.0, d2), std::pow(1.0 + 2.0 * f / d2, -0.5 * d2), 1e-12) << f << " " << d2;
    }
    EXPECT_NEAR(mic::f_tail_probability(f, 1.0, 1.0), 1.0 - 2.0 / M_PI * std::atan(std::sqrt(f)), 1e-12) << f;
  }
  EXPECT_NEAR(mic::f_tail_probability(2.24, 9.0, 28.0), 0.05, 1e-3);  // F(9, 28) table: 2.24 at 5 %
  EXPECT_DOUBLE_EQ(mic::f_tail_probability(0.0, 9.0, 28.0), 1.0);
  // Hotelling's T^2 over 9 entries, T^2 = a F(9, d2), d2 = nu - 8, a = 9 nu / d2: its moments, chi2's for
  // a known covariance (9 and 18), none for nu <= 12.
  const double inf = std::numeric_limits<double>::infinity();
  const mic::QuadraticFormMoments known = mic::quadratic_form_moments(inf, 9);
  EXPECT_DOUBLE_EQ(known.mean, 9.0);
  EXPECT_DOUBLE_EQ(known.variance, 18.0);
  const mic::QuadraticFormMoments m72 = mic::quadratic_form_moments(72.0, 9);
  EXPECT_NEAR(m72.mean, 9.0 * 72.0 / 62.0, 1e-12);  // p nu / (nu - p - 1)
  EXPECT_GT(m72.variance, 18.0);
  EXPECT_TRUE(std::isnan(mic::quadratic_form_moments(12.0, 9).variance));
}

TEST(CalibrationChange, OneHourWindowsCarryTheirCellsIntoTheTest) {
  // A one-hour window at 1 s in 0.0002-0.01 Hz holds harmonics 1-36: both estimators'
  // covariances rest on at most 36 cells; the change check refers chi2 to Hotelling's tail with
  // their combined freedom.
  const mic::SimulatedPair first = mic::test::simulated_hour(44);
  const mic::SimulatedPair second = mic::test::simulated_hour(45);
  mic::WindowEstimator plain(mic::test::plain_eq2_settings()), robust(mic::EstimatorSettings{});
  const mic::WindowEstimate p1 = plain.estimate(first.reference.values_nT, first.test.values_nT, 1.0);
  // At most the 36 cells, fewer as the red field spectrum's low harmonics carry more of the
  // sandwich (test_sandwich_cells.cpp), and more than the 12 at which T^2's variance ends.
  EXPECT_LE(p1.covariance_dof, 36.0);
  EXPECT_GT(p1.covariance_dof, 12.0);
  const mic::WindowEstimate r1 = robust.estimate(first.reference.values_nT, first.test.values_nT, 1.0);
  const mic::WindowEstimate r2 = robust.estimate(second.reference.values_nT, second.test.values_nT, 1.0);
  ASSERT_EQ(r1.quality, mic::Quality::kOk) << r1.quality_text;
  EXPECT_GT(r1.covariance_dof, 12.0);
  EXPECT_LE(r1.covariance_dof, 36.0);
  const mic::CalibrationChange c = mic::check_calibration_change(r1, r2);
  ASSERT_NE(c.status, mic::CalibrationChangeStatus::kInconclusive) << c.text;
  EXPECT_EQ(c.covariance_dof, std::min(r1.covariance_dof, r2.covariance_dof));
  // The joint reference: half of each window's Hotelling T^2 moments (estimate_comparison.hpp).
  const mic::QuadraticFormMoments m1 = mic::quadratic_form_moments(r1.covariance_dof, 9);
  const mic::QuadraticFormMoments m2 = mic::quadratic_form_moments(r2.covariance_dof, 9);
  const double mean = 0.5 * (m1.mean + m2.mean), variance = 0.5 * (m1.variance + m2.variance);
  EXPECT_NEAR(c.p_value, mic::chi2_tail_probability(c.chi2 * 2.0 * mean / variance, 2.0 * mean * mean / variance), 1e-15);
  // Heavier in the tail than chi2's: at chi2's 1e-3 point the reference's tail is larger.
  EXPECT_GT(mic::chi2_tail_probability(27.877 * 2.0 * mean / variance, 2.0 * mean * mean / variance), 0.001);
  EXPECT_NE(c.text.find("cells"), std::string::npos) << c.text;
  EXPECT_FALSE(c.joint_tested);  // under 36 cells each: the parameters decide (next test)
  EXPECT_NE(c.text.find("the parameters one by one"), std::string::npos) << c.text;
}

namespace {

/// A window of n = diag(1, 1, z) with every entry's and parameter's standard error 0.01 (angles
/// 0 +- 0.5 deg), its covariance from `cells` spectral cells.
mic::WindowEstimate hand_window(double z, double cells) {
  mic::WindowEstimate w;
  w.n = Eigen::Vector3d(1.0, 1.0, z).asDiagonal();
  w.n_covariance = mic::Matrix9d::Identity() * 1e-4;
  w.covariance_dof = cells;
  w.parameters.scale_ratio = Eigen::Vector3d(1.0, 1.0, z);
  const double q = w.parameters.interval_quantile;  // the normal's: no cells given to decompose
  w.parameters.scale_ratio_ci95.setConstant(0.01 * q);
  w.parameters.nonorthogonality_ci95_deg.setConstant(0.5 * q);
  w.parameters.misalignment_ci95_deg.setConstant(0.5 * q);
  return w;
}

}  // namespace

TEST(CalibrationChange, JointTestDecidesOnlyOnCovariancesOfEnoughCells) {
  // z scale 1.00 then 1.07, standard errors 0.01 each: z = 0.07 / sqrt(2e-4), z^2 = 24.5. Jointly,
  // over the nine entries of n, chi2 = 24.5 on 9 dof (p 0.0036 for known covariances, more from
  // 36 cells: not below 1e-3): one parameter's move is diluted among nine entries, which is why
  // the parameters are tested too. One by one, the z scale's tail is chi2(1)'s for known variances
  // (p 7.4e-7) and F(1, 48)'s for two windows of 24 cells (Welch-Satterthwaite:
  // (2e-4)^2 / (2 x 1e-8 / 24) = 48), under 1e-3 / 9 either way: a change.
  const double inf = std::numeric_limits<double>::infinity();
  for (double cells : {inf, mic::kJointTestMinCells}) {
    const mic::CalibrationChange c = mic::check_calibration_change(hand_window(1.0, cells), hand_window(1.07, cells));
    EXPECT_NEAR(c.chi2, 24.5, 1e-9);
    EXPECT_TRUE(c.joint_tested) << cells;
    EXPECT_GT(c.p_value, 1e-3) << c.text;
    EXPECT_LT(c.parameter_p_value, 1e-3 / 9.0) << c.text;
    EXPECT_TRUE(c.significant) << c.text;
    EXPECT_EQ(c.status, mic::CalibrationChangeStatus::kChanged) << c.text;
  }
  EXPECT_NEAR(mic::check_calibration_change(hand_window(1.0, inf), hand_window(1.07, inf)).parameter_p_value,
              mic::chi2_tail_probability(24.5, 1.0), 1e-15);
  const mic::CalibrationChange few = mic::check_calibration_change(hand_window(1.0, 24.0), hand_window(1.07, 24.0));
  EXPECT_FALSE(few.joint_tested);
  EXPECT_NEAR(few.scale_z(2), std::sqrt(24.5), 1e-9);
  EXPECT_NEAR(few.parameter_p_value, mic::f_tail_probability(24.5, 1.0, 48.0), 1e-15);
  EXPECT_LT(few.parameter_p_value, 1e-3 / 9.0);
  EXPECT_GT(few.parameter_p_value, mic::chi2_tail_probability(24.5, 1.0));  // Student's tail is heavier
  EXPECT_TRUE(few.significant);
  EXPECT_EQ(few.status, mic::CalibrationChangeStatus::kChanged) << few.text;
  EXPECT_NE(few.text.find("not tested: a covariance from 24 cells, under 36"), std::string::npos) << few.text;
  EXPECT_NE(few.text.find("scale z"), std::string::npos) << few.text;
  // A move of 0.05 (z^2 12.5 on F(1, 48)) is not significant at the parameters' 1e-3 / 9.
  const mic::CalibrationChange small = mic::check_calibration_change(hand_window(1.0, 24.0), hand_window(1.05, 24.0));
  EXPECT_NEAR(small.parameter_p_value, mic::f_tail_probability(12.5, 1.0, 48.0), 1e-15);
  EXPECT_FALSE(small.significant) << small.text;
  // Coupling that only the joint test sees: n(0, 1) moves by 0.1 (chi2 50) while every
  // parameter stays; significant when the joint test decides, not one by one.
  mic::WindowEstimate coupled = hand_window(1.0, mic::kJointTestMinCells);
  coupled.n(0, 1) = 0.1;
  EXPECT_TRUE(mic::check_calibration_change(hand_window(1.0, mic::kJointTestMinCells), coupled).significant);
  coupled.covariance_dof = 24.0;
  EXPECT_FALSE(mic::check_calibration_change(hand_window(1.0, mic::kJointTestMinCells), coupled).significant);
}

TEST(CalibrationChange, DetectsAScaleStepAndNotTheNoise) {
  mic::SimulationSettings s;
  s.seed = 41;
  s.variation_rms_nT = 12.5;
  s.keep_clean_field = false;
  const mic::SimulatedPair first = mic::simulate_pair(s);
  s.seed = 42;
  const mic::SimulatedPair second = mic::simulate_pair(s);  // same instrument, another day
  Eigen::Vector3d changed_scale = s.scale_ratio;
  changed_scale(2) *= 1.005;  // +0.5 % on z (one day of the weak z resolves ~0.07 %)
  s.n_explicit = mic::matrix_from_angles(changed_scale, s.nonorthogonality_deg, s.misalignment_deg);
  s.seed = 43;
  const mic::SimulatedPair third = mic::simulate_pair(s);

  mic::WindowEstimator estimator(mic::EstimatorSettings{});
  const mic::WindowEstimate accepted = estimator.estimate(first.reference.values_nT, first.test.values_nT, 1.0);
  const mic::WindowEstimate same = estimator.estimate(second.reference.values_nT, second.test.values_nT, 1.0);
  const mic::WindowEstimate moved = estimator.estimate(third.reference.values_nT, third.test.values_nT, 1.0);

  const mic::CalibrationChange none = mic::check_calibration_change(accepted, same);
  EXPECT_EQ(none.status, mic::CalibrationChangeStatus::kUnchanged) << none.text << "\n" << accepted.n << "\n" << same.n
                                                                   << "\n" << accepted.n_stderr() << "\n" << same.n_stderr();
  EXPECT_GT(none.p_value, 1e-3);
  const mic::CalibrationChange step = mic::check_calibration_change(accepted, moved);
  EXPECT_EQ(step.status, mic::CalibrationChangeStatus::kChanged) << step.text;
  EXPECT_NEAR(step.scale_difference(2), 0.005, 0.002);
  EXPECT_GT(step.scale_z(2), 3.0);
  EXPECT_NE(step.text.find("scale z"), std::string::npos) << step.text;

  // A practical tolerance above the step silences it.
  mic::CalibrationChangeSettings lenient;
  lenient.scale_tolerance = 0.02;
  lenient.angle_tolerance_deg = 1.0;
  EXPECT_EQ(mic::check_calibration_change(accepted, moved, lenient).status, mic::CalibrationChangeStatus::kUnchanged);

  mic::WindowEstimate flagged = moved;
  flagged.quality = mic::Quality::kLowCoherence;
  EXPECT_EQ(mic::check_calibration_change(accepted, flagged).status, mic::CalibrationChangeStatus::kInconclusive);
}
