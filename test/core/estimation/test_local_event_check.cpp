// The local-event check (estimation/local_event_check.hpp) on simulated pairs with known truth:
// what it must see (traffic both sensors see with different gains, events at the reference
// alone), what it must not (a quiet pair, events at the test alone, a test behind a filter and a
// delay, straight-line fills of gaps) and when it cannot say (a short window).
#include "magnetometer_insitu_calibration/estimation/local_event_check.hpp"

#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/estimation/robust/robust_estimator.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "magnetometer_insitu_calibration/simulation/unmodelled_disturbances.hpp"

#include "busy_road.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace mic = magnetometer_insitu_calibration;

namespace {

constexpr double kBandTopHz = 0.01;  // the default band's top: event band 0.02-0.2 Hz at 1 s

mic::SimulationSettings event_station(std::uint64_t seed, double days = 1.0) {
  return mic::test::quiet_station(seed, days * 86400.0);
}

using mic::test::add_busy_road;

mic::LocalEventCheck check(const mic::SimulatedPair& pair, double delay_s = std::nan("")) {
  return mic::check_local_events(pair.reference.values_nT, pair.test.values_nT, 1.0, kBandTopHz, delay_s);
}

}  // namespace

TEST(LocalEventCheck, QuietPairsShowNoEvents) {
  // Ten held-out days: z is a standard normal when nothing local is there (one-sided 1 % level:
  // no day should be called, and the mean of ten z's is within 3 of its standard error 0.32).
  double sum = 0.0;
  int seen = 0;
  for (std::uint64_t seed = 61000; seed < 61010; ++seed) {
    const mic::LocalEventCheck c = check(mic::simulate_pair(event_station(seed)));
    ASSERT_TRUE(c.assessed) << c.text;
    EXPECT_EQ(c.blocks, 674) << c.text;  // 86400 s less one difference, in 128 s blocks
    EXPECT_DOUBLE_EQ(c.low_hz, 0.02);
    EXPECT_NEAR(c.high_hz, 0.2, 1e-12);
    sum += c.z;
    seen += c.seen;
    EXPECT_EQ(c.seen, c.p_value < mic::kLocalEventAlpha);
    EXPECT_NEAR(c.p_value, 0.5 * std::erfc(c.z / std::sqrt(2.0)), 1e-12);
  }
  EXPECT_LE(seen, 1);
  EXPECT_LT(std::abs(sum / 10.0), 3.0 / std::sqrt(10.0));
}

TEST(LocalEventCheck, TrafficBothSensorsSeeIsSeen) {
  // Two days (z 8.0-11.2 on these seeds; one day gave 2.0-3.7, the Monte Carlo's 5-day records 9-24).
  for (std::uint64_t seed : {61100, 61101, 61102}) {
    mic::SimulatedPair pair = mic::simulate_pair(event_station(seed, 2.0));
    add_busy_road(pair, seed);
    const mic::LocalEventCheck c = check(pair);
    ASSERT_TRUE(c.assessed) << c.text;
    EXPECT_TRUE(c.seen) << c.text;
    EXPECT_GT(c.z, 4.0) << c.text;
    EXPECT_NE(c.text.find("not vouched for"), std::string::npos) << c.text;
  }
}

TEST(LocalEventCheck, EventsAtTheReferenceAloneAreSeenAtTheTestAloneNot) {
  // The same vehicles, once only in the reference (an error in the regressor: a bias) and once
  // only in the test (noise in the response: no bias).
  const std::uint64_t seed = 61200;
  const mic::SimulatedPair clean = mic::simulate_pair(event_station(seed));
  mic::SimulatedPair both = clean;
  const mic::StationDisturbanceReport road = add_busy_road(both, seed);
  mic::SimulatedPair reference_only = clean, test_only = clean;
  reference_only.reference.values_nT += road.reference_added_nT;
  test_only.test.values_nT += road.test_added_nT;
  const mic::LocalEventCheck at_reference = check(reference_only), at_test = check(test_only);
  EXPECT_TRUE(at_reference.seen) << at_reference.text;
  EXPECT_GT(at_reference.z, 4.0) << at_reference.text;
  EXPECT_FALSE(at_test.seen) << at_test.text;
  EXPECT_LT(at_test.z, 2.0) << at_test.text;
}

TEST(LocalEventCheck, ATestBehindAFilterAndADelayShowsNoEvents) {
  // A 0.03 Hz one-pole low-pass and 2 s delay change the test's response across the whole event
  // band; H at each harmonic takes it and the blocks are aligned by the delay.
  int seen = 0;
  double sum = 0.0;
  for (std::uint64_t seed = 61300; seed < 61306; ++seed) {
    mic::SimulatedPair pair = mic::simulate_pair(event_station(seed));
    mic::apply_test_response(pair.test.values_nT, 1.0, 0.03, 2.0);
    const mic::LocalEventCheck c = check(pair, 2.0);
    seen += c.seen;
    sum += c.z;
  }
  EXPECT_LE(seen, 1);
  EXPECT_LT(std::abs(sum / 6.0), 3.0 / std::sqrt(6.0));
}

TEST(LocalEventCheck, StraightLineFillsAreLeftOut) {
  // Gaps filled by straight lines in both records (as the pipeline and the screen fill them) make
  // a block quiet in R and in E together; such blocks are left out, not taken for events.
  mic::SimulatedPair pair = mic::simulate_pair(event_station(61400));
  mic::Readings& r = pair.reference.values_nT;
  mic::Readings& t = pair.test.values_nT;
  int runs = 0;
  for (Eigen::Index start = 500; start + 400 < r.rows(); start += 1100, ++runs) {
    const Eigen::Index length = 60 + (start % 7) * 40;  // 60 to 300 s
    for (mic::Readings* x : {&r, &t}) {
      const Eigen::RowVector3d a = x->row(start - 1), b = x->row(start + length);
      for (Eigen::Index i = 0; i < length; ++i) {
        x->row(start + i) = a + (b - a) * static_cast<double>(i + 1) / static_cast<double>(length + 1);
      }
    }
  }
  const mic::LocalEventCheck c = check(pair);
  ASSERT_TRUE(c.assessed) << c.text;
  EXPECT_GE(674 - c.blocks, runs) << c.text;  // every fill takes its block(s)
  EXPECT_FALSE(c.seen) << c.text;
  EXPECT_NE(c.text.find("with fills left out"), std::string::npos) << c.text;
}

TEST(LocalEventCheck, ShortWindowsAndNoEventBandAreNotAssessed) {
  const mic::SimulatedPair pair = mic::simulate_pair(event_station(61500, 2.0 / 24.0));
  const mic::LocalEventCheck short_window = check(pair);
  EXPECT_FALSE(short_window.assessed);
  EXPECT_FALSE(short_window.seen);
  EXPECT_TRUE(std::isnan(short_window.p_value));
  EXPECT_NE(short_window.text.find("not assessed: 56 blocks"), std::string::npos) << short_window.text;
  // A band reaching 0.1 Hz at 1 s: the event band would start at 0.2 Hz, above 0.4 / period / 4.
  const mic::SimulatedPair day = mic::simulate_pair(event_station(61501));
  const mic::LocalEventCheck high_band =
      mic::check_local_events(day.reference.values_nT, day.test.values_nT, 1.0, 0.1, std::nan(""));
  EXPECT_FALSE(high_band.assessed);
  EXPECT_NE(high_band.text.find("no event band"), std::string::npos) << high_band.text;
}

TEST(LocalEventCheck, TheDefaultEstimatorRunsItWithoutARemotePlainEq2DoesNot) {
  mic::SimulatedPair pair = mic::simulate_pair(event_station(61600, 2.0));
  add_busy_road(pair, 61600);
  mic::EstimatorSettings robust;
  mic::WindowEstimator estimator(robust);
  const mic::WindowEstimate e = estimator.estimate(pair.reference.values_nT, pair.test.values_nT, 1.0);
  ASSERT_TRUE(e.local_events.assessed) << e.local_events.text;
  EXPECT_TRUE(e.local_events.seen) << e.local_events.text;
  mic::EstimatorSettings plain;
  plain.method = mic::EstimatorMethod::kPlain;
  mic::WindowEstimator eq2(plain);
  const mic::WindowEstimate p = eq2.estimate(pair.reference.values_nT, pair.test.values_nT, 1.0);
  EXPECT_FALSE(p.local_events.assessed);
}
