// Delay from the cross-spectral phase: simulated delays of 5 to 50 ms recovered within 1 ms.
#include "magnetometer_insitu_calibration/estimation/delay_estimation.hpp"
#include "magnetometer_insitu_calibration/estimation/robust_estimator.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace mic = magnetometer_insitu_calibration;

namespace {
mic::SimulationSettings station(std::uint64_t seed, double delay_s) {
  mic::SimulationSettings s;
  s.seed = seed;
  s.variation_rms_nT = 12.5;
  s.delay_s = delay_s;
  s.keep_clean_field = false;
  return s;
}
}  // namespace

TEST(DelayEstimation, RecoversFiveToFiftyMillisecondsWithinOneMillisecond) {
  for (double delay : {0.0, 0.005, 0.020, -0.012, 0.050}) {
    const mic::SimulatedPair pair = mic::simulate_pair(station(21, delay));
    const mic::DelayEstimate d = mic::estimate_delay(pair.reference.values_nT, pair.test.values_nT, pair.n_true, 1.0);
    ASSERT_TRUE(d.ok) << d.text;
    EXPECT_NEAR(d.delay_s, delay, 0.001) << d.text;
    EXPECT_LT(std::abs(d.delay_s - delay), 4.0 * d.stderr_s) << d.text;  // the interval is honest
    EXPECT_LT(d.ci95_s, 0.002) << d.text;                                 // and informative
  }
}

TEST(DelayEstimation, ReportedPerWindowByTheRobustEstimator) {
  const mic::SimulatedPair pair = mic::simulate_pair(station(22, 0.030));
  mic::WindowEstimator estimator(mic::EstimatorSettings{});
  const mic::WindowEstimate e = estimator.estimate(pair.reference.values_nT, pair.test.values_nT, 1.0);
  EXPECT_NEAR(e.delay_s, 0.030, 0.001);
  EXPECT_GT(e.delay_ci95_s, 0.0);
  EXPECT_LT(e.delay_ci95_s, 0.003);
  EXPECT_TRUE(estimator.robust_diagnostics()->delay_corrected);
}

TEST(DelayEstimation, UnrelatedRecordsGiveNoDelay) {
  const mic::SimulatedPair a = mic::simulate_pair(station(23, 0.0));
  const mic::SimulatedPair b = mic::simulate_pair(station(24, 0.0));
  const mic::DelayEstimate d = mic::estimate_delay(a.reference.values_nT, b.test.values_nT, a.n_true, 1.0);
  EXPECT_FALSE(d.ok) << d.text;
}
