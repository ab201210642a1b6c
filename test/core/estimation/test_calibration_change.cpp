// Calibration change: unchanged between two days of one instrument, changed after a 0.5 % scale
// step, inconclusive for a flagged window; the chi^2 tail against tabulated values.
#include "magnetometer_insitu_calibration/estimation/calibration_change.hpp"
#include "magnetometer_insitu_calibration/estimation/calibration_matrix.hpp"
#include "magnetometer_insitu_calibration/estimation/robust_estimator.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <gtest/gtest.h>

namespace mic = magnetometer_insitu_calibration;

TEST(CalibrationChange, ChiSquareTailMatchesTables) {
  EXPECT_NEAR(mic::chi2_tail_probability(16.919, 9), 0.05, 2e-4);
  EXPECT_NEAR(mic::chi2_tail_probability(27.877, 9), 0.001, 2e-5);
  EXPECT_NEAR(mic::chi2_tail_probability(3.841, 1), 0.05, 2e-4);
  EXPECT_NEAR(mic::chi2_tail_probability(2.088, 9), 0.99, 2e-4);
  EXPECT_DOUBLE_EQ(mic::chi2_tail_probability(0.0, 9), 1.0);
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
  EXPECT_NE(step.text.find("Kz"), std::string::npos) << step.text;

  // A practical tolerance above the step silences it.
  mic::CalibrationChangeSettings lenient;
  lenient.scale_tolerance = 0.02;
  lenient.angle_tolerance_deg = 1.0;
  EXPECT_EQ(mic::check_calibration_change(accepted, moved, lenient).status, mic::CalibrationChangeStatus::kUnchanged);

  mic::WindowEstimate flagged = moved;
  flagged.quality = mic::Quality::kLowCoherence;
  EXPECT_EQ(mic::check_calibration_change(accepted, flagged).status, mic::CalibrationChangeStatus::kInconclusive);
}
