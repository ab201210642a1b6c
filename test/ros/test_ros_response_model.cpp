// ROS layer without a master, response model (issue 14): calibration_node's window estimate
// (live_window.hpp) on a test instrument behind a 1-pole low-pass at 0.03 Hz and a 2 s delay,
// against the known n of the simulation, with ~response_model on (the default) and off.
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "magnetometer_insitu_calibration/ros/live_window.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "magnetometer_insitu_calibration/simulation/unmodelled_disturbances.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

namespace mic = magnetometer_insitu_calibration;

namespace {

struct FilteredWindow {
  mic::SimulatedPair pair;
  mic::WindowData window;
};

/// A 12 h window at 1 Hz of the simulator's quiet pair (reference 3x quieter than the test, as a
/// certified reference beside a field instrument), the test behind corner_hz (0: none) and delay_s.
FilteredWindow filtered_window(std::uint64_t seed, double corner_hz, double delay_s) {
  mic::SimulationSettings s;
  s.seed = seed;
  s.duration_s = 43200.0;
  s.reference_white_nT = 0.0033;
  s.reference_pink_nT_per_sqrt_hz = 0.0017;
  FilteredWindow f;
  f.pair = mic::simulate_pair(s);
  mic::apply_test_response(f.pair.test.values_nT, s.sample_period_s, corner_hz, delay_s);
  mic::WindowData& w = f.window;
  w.start_s = f.pair.reference.time_s.front();
  w.period_s = s.sample_period_s;
  w.expected_samples = f.pair.reference.size();
  w.paired.time_s = f.pair.reference.time_s;
  w.paired.reference_nT = f.pair.reference.values_nT;
  w.paired.test_nT = f.pair.test.values_nT;
  return f;
}

/// Largest |scale-ratio error| over the three axes: in the estimate's own standard errors
/// (in_se) or as a fraction.
double worst_scale_error(const mic::WindowEstimate& e, const Eigen::Matrix3d& truth, bool in_se) {
  const mic::CalibrationParameters t = mic::decompose(truth);
  double worst = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double se = in_se ? e.parameters.scale_ratio_ci95(k) / e.parameters.interval_quantile : 1.0;
    worst = std::max(worst, std::abs(e.parameters.scale_ratio(k) - t.scale_ratio(k)) / se);
  }
  return worst;
}

}  // namespace

TEST(LiveResponseModel, EstimatesNThroughAFilteredTestAndShowsTheFilter) {
  // MIC_LIVE_RESPONSE_SEED: another seed (checked on 41-60 when written).
  const char* seed = std::getenv("MIC_LIVE_RESPONSE_SEED");
  const FilteredWindow f = filtered_window(seed != nullptr ? std::strtoull(seed, nullptr, 10) : 41, 0.03, 2.0);
  mic::WindowEstimator estimator{mic::EstimatorSettings{}};
  mic::WindowGapRule rule;
  ASSERT_TRUE(rule.response_model) << "the model is on by default (~response_model)";
  const mic::WindowResult on = mic::estimate_window(f.window, estimator, rule);
  ASSERT_EQ(on.estimate.quality, mic::Quality::kOk) << on.estimate.quality_text;
  ASSERT_TRUE(on.response_model.applied) << on.response_model.text;
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(on.response_model.corner_hz(k), 0.03, 0.003) << "component " << k;
  }
  EXPECT_NEAR(on.response_model.delay_s, 2.0, 0.2);
  EXPECT_LT(worst_scale_error(on.estimate, f.pair.n_true, true), 3.5);

  rule.response_model = false;
  const mic::WindowResult off = mic::estimate_window(f.window, estimator, rule);
  EXPECT_FALSE(off.response_model.fitted);
  EXPECT_NE(off.response_model.text.find("~response_model false"), std::string::npos) << off.response_model.text;
  // Without the model the filter's roll-off is taken for a loss of gain: several times the error.
  EXPECT_GT(worst_scale_error(off.estimate, f.pair.n_true, false),
            3.0 * worst_scale_error(on.estimate, f.pair.n_true, false));

  // The response reported is that of the test as recorded: the filter shows (gain 0.949 at 0.01 Hz).
  bool seen = false;
  for (const mic::ResponseBand& b : on.relative_response) {
    if (b.frequency_hz < 0.008 || b.frequency_hz > 0.012) continue;
    seen = true;
    const double truth = 1.0 / std::hypot(1.0, b.frequency_hz / 0.03);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(b.gain(k), truth, 0.02) << b.frequency_hz << " Hz, component " << k;
  }
  EXPECT_TRUE(seen);
}

TEST(LiveResponseModel, LeavesAMatchedPairAlone) {
  const FilteredWindow f = filtered_window(42, 0.0, 0.0);
  mic::WindowEstimator estimator{mic::EstimatorSettings{}};
  mic::WindowGapRule rule;
  const mic::WindowResult on = mic::estimate_window(f.window, estimator, rule);
  rule.response_model = false;
  const mic::WindowResult off = mic::estimate_window(f.window, estimator, rule);
  EXPECT_TRUE(on.response_model.fitted) << on.response_model.text;
  EXPECT_FALSE(on.response_model.applied) << on.response_model.text;
  EXPECT_EQ((on.estimate.n - off.estimate.n).cwiseAbs().maxCoeff(), 0.0);
}

TEST(LiveResponseModel, ThePlainEstimatorSaysItFitsNoModel) {
  const FilteredWindow f = filtered_window(43, 0.03, 2.0);
  mic::FdWlseEstimator plain;
  const mic::WindowResult r = mic::estimate_window(f.window, plain, mic::WindowGapRule{});
  EXPECT_FALSE(r.response_model.fitted);
  EXPECT_NE(r.response_model.text.find("plain"), std::string::npos) << r.response_model.text;
}
