// Agreement of disjoint windows within their intervals: chi^2 worked by hand, windows of another
// quality left out, four simulated days of one instrument agreeing and four with a 1 % z scale
// step after the second disagreeing, named.
#include "magnetometer_insitu_calibration/estimation/window_agreement.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/estimation/calibration_change.hpp"
#include "magnetometer_insitu_calibration/estimation/calibration_matrix.hpp"
#include "magnetometer_insitu_calibration/estimation/robust/robust_estimator.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

namespace mic = magnetometer_insitu_calibration;

namespace {

/// A window of n = diag(1, 1, z): scale ratios (1, 1, z), every standard error 0.01 except z's,
/// se_z; angles 0 +- 0.5 deg (ci95 half-width ~0.98 deg).
mic::WindowEstimate window(double z, double se_z) {
  mic::WindowEstimate w;
  w.n = Eigen::Vector3d(1.0, 1.0, z).asDiagonal();
  w.n_covariance = mic::Matrix9d::Identity() * 1e-4;
  w.n_covariance(8, 8) = se_z * se_z;
  mic::CalibrationParameters& p = w.parameters;
  p.scale_ratio = Eigen::Vector3d(1.0, 1.0, z);
  // Half-widths in the parameters' own quantile (the normal's: no cells set here).
  p.scale_ratio_ci95 = Eigen::Vector3d(0.01, 0.01, se_z) * p.interval_quantile;
  p.nonorthogonality_ci95_deg.setConstant(0.5 * p.interval_quantile);
  p.misalignment_ci95_deg.setConstant(0.5 * p.interval_quantile);
  return w;
}

}  // namespace

TEST(WindowAgreement, ChiSquareWorkedByHand) {
  // z scale 1.00, 1.02, 0.99 with standard errors 0.01, 0.01, 0.02: weights 1e4, 1e4, 2500, the
  // weighted mean 22675 / 22500 = 1.0077778, chi2 = 0.6049383 + 1.4938272 + 0.7901235 = 26 / 9.
  // Two degrees of freedom: tail probability exp(-chi2 / 2) exactly.
  const std::vector<mic::WindowEstimate> windows = {window(1.00, 0.01), window(1.02, 0.01), window(0.99, 0.02)};
  const mic::WindowAgreement a = mic::check_window_agreement(windows);
  ASSERT_TRUE(a.assessed) << a.text;
  EXPECT_EQ(a.windows, 3);
  const mic::ParameterAgreement& z = a.parameters[2];
  EXPECT_NEAR(z.weighted_mean, 22675.0 / 22500.0, 1e-12);
  EXPECT_NEAR(z.chi2, 26.0 / 9.0, 1e-9);
  EXPECT_NEAR(z.birge_ratio, std::sqrt(13.0 / 9.0), 1e-9);
  EXPECT_NEAR(z.p_value, std::exp(-13.0 / 9.0), 1e-9);
  for (int k : {0, 1, 3, 4, 5, 6, 7, 8})
    EXPECT_EQ(a.parameters[k].chi2, 0.0) << mic::kParameters[static_cast<std::size_t>(k)].name;
  // Jointly: diagonal covariances, so the other eight entries add nothing; 9 x 2 dof.
  EXPECT_NEAR(a.joint_chi2, 26.0 / 9.0, 1e-9);
  EXPECT_EQ(a.joint_dof, 18);
  EXPECT_NEAR(a.joint_p_value, mic::chi2_tail_probability(26.0 / 9.0, 18), 1e-12);
  EXPECT_TRUE(a.agree);
  EXPECT_NE(a.text.find("3 windows agree within their intervals"), std::string::npos) << a.text;
  EXPECT_NE(a.text.find("scale z"), std::string::npos) << a.text;

  // Spread five times wider: chi2 x 25 = 72.2, p of scale z 2e-16 < 0.01 / 9.
  const std::vector<mic::WindowEstimate> apart = {window(1.00, 0.002), window(1.02, 0.002), window(0.99, 0.004)};
  const mic::WindowAgreement b = mic::check_window_agreement(apart);
  EXPECT_NEAR(b.parameters[2].chi2, 25.0 * 26.0 / 9.0, 1e-6);
  EXPECT_FALSE(b.agree);
  EXPECT_NE(b.text.find("disagree beyond their intervals"), std::string::npos) << b.text;
  EXPECT_NE(b.text.find("scale z"), std::string::npos) << b.text;
}

TEST(WindowAgreement, CovariancesFromFewCellsRaiseTheExpectedChiSquare) {
  // The same three windows, each covariance estimated from nu = 36 spectral cells (a one-hour
  // window). Per parameter, Welch's test: weights 1e4, 1e4, 2500 (W 22500), so
  // h = ((5/9)^2 + (5/9)^2 + (8/9)^2) / 36 = 114 / 2916, c = 1 + 2 (K - 2) h / (K^2 - 1) = 1 + h / 4,
  // F = chi2 / (2 c) on (2, d2 = 8 / (3 h)) dof, whose tail is (1 + 2 F / d2)^(-d2 / 2), and the
  // expected chi2 2 c d2 / (d2 - 2). Jointly each window contributes (K - 1) / K = 2/3 of its
  // Hotelling T^2's mean 9 nu / (nu - 10): 3 x 2/3 x 9 x 36/26 = 648/26.
  std::vector<mic::WindowEstimate> windows = {window(1.00, 0.01), window(1.02, 0.01), window(0.99, 0.02)};
  for (mic::WindowEstimate& w : windows) w.covariance_dof = 36.0;
  const mic::WindowAgreement a = mic::check_window_agreement(windows);
  ASSERT_TRUE(a.assessed) << a.text;
  const mic::ParameterAgreement& z = a.parameters[2];
  EXPECT_NEAR(z.chi2, 26.0 / 9.0, 1e-9);  // the statistic itself is unchanged
  const double h = 114.0 / 2916.0, c = 1.0 + h / 4.0, d2 = 8.0 / (3.0 * h);
  EXPECT_NEAR(z.expected_chi2, 2.0 * c * d2 / (d2 - 2.0), 1e-12);
  EXPECT_NEAR(z.birge_ratio, std::sqrt((26.0 / 9.0) / (2.0 * c * d2 / (d2 - 2.0))), 1e-9);
  EXPECT_NEAR(z.p_value, std::pow(1.0 + 2.0 * (26.0 / 9.0) / (2.0 * c) / d2, -0.5 * d2), 1e-12);
  EXPECT_GT(z.p_value, std::exp(-13.0 / 9.0));  // a heavier tail than chi2's: less significant
  EXPECT_NEAR(a.joint_expected_chi2, 648.0 / 26.0, 1e-9);
  EXPECT_NE(a.text.find("expected"), std::string::npos) << a.text;
  // Known covariances (the default): the chi2 of the test above.
  for (mic::WindowEstimate& w : windows) w.covariance_dof = std::numeric_limits<double>::infinity();
  EXPECT_NEAR(mic::check_window_agreement(windows).parameters[2].p_value, std::exp(-13.0 / 9.0), 1e-9);
}

TEST(WindowAgreement, JointTestDecidesOnlyOnCovariancesOfEnoughCells) {
  // Three windows whose x-y coupling (n(0, 1), 0 +- 0.01) is 0, +0.1, -0.1 while their reported
  // parameters all agree: the joint test over vec(n) sees it (chi2 200 on n(0, 1) alone, 18
  // dof), the parameters do not (chi2 0). With known covariances or 36 cells each the joint test
  // decides; with one window's covariance from 24 cells (a one-hour window) the parameters decide
  // one by one, and agree.
  std::vector<mic::WindowEstimate> windows = {window(1.0, 0.01), window(1.0, 0.01), window(1.0, 0.01)};
  windows[1].n(0, 1) = 0.1;
  windows[2].n(0, 1) = -0.1;
  const mic::WindowAgreement known = mic::check_window_agreement(windows);
  ASSERT_TRUE(known.assessed) << known.text;
  EXPECT_NEAR(known.joint_chi2, 200.0, 1e-9);  // (0.1^2 + 0.1^2) / 1e-4
  EXPECT_TRUE(known.joint_tested);
  EXPECT_LT(known.joint_p_value, 0.01);
  EXPECT_FALSE(known.agree) << known.text;
  for (mic::WindowEstimate& w : windows) w.covariance_dof = mic::kJointTestMinCells;
  const mic::WindowAgreement enough = mic::check_window_agreement(windows);
  EXPECT_TRUE(enough.joint_tested);
  EXPECT_FALSE(enough.agree) << enough.text;
  windows[1].covariance_dof = 24.0;
  const mic::WindowAgreement few = mic::check_window_agreement(windows);
  EXPECT_FALSE(few.joint_tested);
  EXPECT_NEAR(few.joint_chi2, 200.0, 1e-9);  // still computed and printed
  EXPECT_TRUE(few.agree) << few.text;
  EXPECT_NE(few.text.find("not tested: a covariance from 24 cells, under 36"), std::string::npos) << few.text;
}

TEST(WindowAgreement, WindowsOfAnotherQualityAreLeftOut) {
  std::vector<mic::WindowEstimate> windows = {window(1.00, 0.01), window(1.02, 0.01), window(0.99, 0.02)};
  mic::WindowEstimate flagged = window(1.5, 0.001);
  flagged.quality = mic::Quality::kLowCoherence;
  windows.push_back(flagged);
  const mic::WindowAgreement a = mic::check_window_agreement(windows);
  EXPECT_EQ(a.windows, 3);
  EXPECT_NEAR(a.parameters[2].chi2, 26.0 / 9.0, 1e-9);

  windows[1].quality = mic::Quality::kIllConditioned;
  EXPECT_EQ(mic::check_window_agreement(windows).windows, 2);
  windows[2].quality = mic::Quality::kGaps;
  const mic::WindowAgreement one = mic::check_window_agreement(windows);
  EXPECT_FALSE(one.assessed);
  EXPECT_NE(one.text.find("not assessed: 1 of 4 windows ok"), std::string::npos) << one.text;

  std::vector<mic::WindowEstimate> no_interval = {window(1.00, 0.01), window(1.02, 0.0)};
  const mic::WindowAgreement none = mic::check_window_agreement(no_interval);
  EXPECT_FALSE(none.assessed);
  EXPECT_NE(none.text.find("no usable interval for scale z"), std::string::npos) << none.text;

  // A covariance from 4 cells or fewer (one strong harmonic carrying the sandwich) has no
  // reference distribution: that window is left out, and the text says so.
  std::vector<mic::WindowEstimate> few_cells = {window(1.00, 0.01), window(1.02, 0.01), window(0.99, 0.02),
                                                window(1.5, 0.001)};
  few_cells[3].covariance_dof = 3.5;
  const mic::WindowAgreement left_out = mic::check_window_agreement(few_cells);
  EXPECT_EQ(left_out.windows, 3);
  EXPECT_NEAR(left_out.parameters[2].chi2, 26.0 / 9.0, 1e-9);
  EXPECT_NE(left_out.text.find("1 ok windows left out, covariances from 4 cells or fewer"), std::string::npos)
      << left_out.text;

  mic::WindowAgreementSettings wrong;
  wrong.significance = 0.7;
  EXPECT_THROW(mic::check_window_agreement(no_interval, wrong), mic::InputError);
}

TEST(WindowAgreement, FourDaysOfOneInstrumentAgreeAndAScaleStepIsNamed) {
  mic::SimulationSettings s;
  s.variation_rms_nT = 12.5;
  s.keep_clean_field = false;
  const Eigen::Matrix3d n_before = mic::matrix_from_angles(s.scale_ratio, s.nonorthogonality_deg, s.misalignment_deg);
  Eigen::Vector3d stepped = s.scale_ratio;
  stepped(2) *= 1.01;  // +1 % on z from the third day (one day of the weak z resolves ~0.1 %)
  const Eigen::Matrix3d n_after = mic::matrix_from_angles(stepped, s.nonorthogonality_deg, s.misalignment_deg);
  mic::WindowEstimator estimator(mic::EstimatorSettings{});
  std::vector<mic::WindowEstimate> same, step;
  for (int day = 0; day < 4; ++day) {
    s.seed = 61 + static_cast<std::uint64_t>(day);
    s.n_explicit = n_before;
    const mic::SimulatedPair a = mic::simulate_pair(s);
    same.push_back(estimator.estimate(a.reference.values_nT, a.test.values_nT, 1.0));
    s.n_explicit = day < 2 ? n_before : n_after;
    const mic::SimulatedPair b = mic::simulate_pair(s);
    step.push_back(estimator.estimate(b.reference.values_nT, b.test.values_nT, 1.0));
  }
  const mic::WindowAgreement a = mic::check_window_agreement(same);
  ASSERT_TRUE(a.assessed) << a.text;
  EXPECT_TRUE(a.agree) << a.text;
  EXPECT_GT(a.joint_p_value, 0.01) << a.text;
  const mic::WindowAgreement b = mic::check_window_agreement(step);
  std::printf("one instrument: %s\nz step: %s\n", a.text.c_str(), b.text.c_str());
  ASSERT_TRUE(b.assessed) << b.text;
  EXPECT_FALSE(b.agree) << b.text;
  EXPECT_LT(b.parameters[2].p_value, 1e-4) << b.text;
  // Day-long windows rest on hundreds of cells: the expected chi2 is K - 1 = 3 within 2 %.
  EXPECT_GE(b.parameters[2].expected_chi2, 3.0);
  EXPECT_LT(b.parameters[2].expected_chi2, 3.06);
  EXPECT_NE(b.text.find("largest sqrt(chi2/3"), std::string::npos) << b.text;
  EXPECT_NE(b.text.find("scale z"), std::string::npos) << b.text;
  // The weighted mean lies between the two calibrations.
  EXPECT_GT(b.parameters[2].weighted_mean, s.scale_ratio(2));
  EXPECT_LT(b.parameters[2].weighted_mean, stepped(2));
}
