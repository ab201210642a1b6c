// The summary's verdicts and record lengths (pipeline/tolerance_verdicts.hpp): the rule against
// hand-worked cases, the predicted length against its formula, and on a simulated record every
// verdict checked against its own value and interval, the narrowing near the 1/2 of a record
// whose signal and noise are equally strong throughout.
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/pipeline/tolerance_verdicts.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace mic = magnetometer_insitu_calibration;

TEST(ToleranceVerdict, DecidesByTheWholeInterval) {
  EXPECT_EQ(mic::decide(1.004, 0.005, 1.0, 0.01), mic::Verdict::kWithin);     // 1.004 +- 0.005 inside 0.99-1.01
  EXPECT_EQ(mic::decide(1.004, 0.007, 1.0, 0.01), mic::Verdict::kUndecided);  // reaches 1.011
  EXPECT_EQ(mic::decide(0.985, 0.004, 1.0, 0.01), mic::Verdict::kOutside);    // 0.981-0.989, all below 0.99
  EXPECT_EQ(mic::decide(0.985, 0.006, 1.0, 0.01), mic::Verdict::kUndecided);  // reaches 0.991
  EXPECT_EQ(mic::decide(-0.2, 0.05, 0.0, 0.1146), mic::Verdict::kOutside);
  EXPECT_EQ(mic::decide(0.05, NAN, 0.0, 0.1146), mic::Verdict::kUndecided);
}

TEST(ToleranceVerdict, RecordNeededFollowsTheMeasuredNarrowing) {
  mic::CalibrationParameters p;
  p.scale_ratio = Eigen::Vector3d(1.002, 1.0, 1.0);
  p.scale_ratio_ci95 = Eigen::Vector3d(0.016, 0.001, 0.001);  // x: 0.002 off, needs a half-width of 0.008
  p.nonorthogonality_deg = Eigen::Vector3d(0.1, 0.0, 0.0);
  p.nonorthogonality_ci95_deg = Eigen::Vector3d(0.3, 0.01, 0.01);
  mic::Tolerances t;
  t.nonorthogonality_deg.setConstant(0.1);  // xy: exactly at the edge
  mic::IntervalNarrowing narrowing;
  narrowing.exponent = 0.5;
  narrowing.sub_windows = 6;
  const double day = 86400.0;
  auto v = mic::tolerance_verdicts(p, t, day, narrowing);
  ASSERT_EQ(v.size(), 9u);
  EXPECT_EQ(v[0].parameter, "scale_x");
  EXPECT_EQ(v[0].verdict, mic::Verdict::kUndecided);
  EXPECT_NEAR(v[0].record_needed_s, 4.0 * day, 1e-6 * day);  // (0.016 / 0.008)^(1/0.5) = 4 days
  EXPECT_EQ(v[1].verdict, mic::Verdict::kWithin);
  EXPECT_TRUE(std::isnan(v[1].record_needed_s));
  EXPECT_EQ(v[3].parameter, "nonorthogonality_xy");
  EXPECT_TRUE(std::isinf(v[3].record_needed_s));  // at the edge, no length decides
  narrowing.exponent = 0.25;                      // a record whose signal comes in bursts
  v = mic::tolerance_verdicts(p, t, day, narrowing);
  EXPECT_NEAR(v[0].record_needed_s, 16.0 * day, 1e-6 * day);
  narrowing.exponent = 0.05;  // the interval does not narrow: no length of such a record decides
  v = mic::tolerance_verdicts(p, t, day, narrowing);
  EXPECT_TRUE(std::isinf(v[0].record_needed_s));
  narrowing.sub_windows = 0;  // not measured: no length stated
  v = mic::tolerance_verdicts(p, t, day, narrowing);
  EXPECT_TRUE(std::isnan(v[0].record_needed_s));
}

TEST(ToleranceVerdict, OnSimulatedDaysEveryVerdictAgreesWithItsIntervalAndTheIntervalsNarrowAsTheSquareRoot) {
  for (std::uint64_t seed : {61001ULL, 61002ULL, 61003ULL}) {
    mic::SimulationSettings s;
    s.seed = seed;
    s.duration_s = 12 * 3600.0;
    const mic::SimulatedPair pair = mic::simulate_pair(s);
    for (double scale_tolerance : {0.01, 0.0004}) {  // INTERMAGNET's and a coil laboratory's
      mic::CalibrationSettings settings;
      settings.window.tolerances.scale.setConstant(scale_tolerance);
      settings.window.tolerances.nonorthogonality_deg.setConstant(scale_tolerance == 0.01 ? 0.1146 : 0.02);
      const mic::PairCalibration c = mic::calibrate_records(pair.reference, pair.test, settings);
      ASSERT_EQ(c.windows.size(), 1u);
      const mic::CalibrationWindow& w = c.windows.front();
      ASSERT_EQ(w.verdicts.size(), 9u);
      bool undecided = false;
      for (const mic::ToleranceVerdict& v : w.verdicts) {
        const double low = v.value - v.ci95, high = v.value + v.ci95;
        const double allowed_low = v.nominal - v.tolerance, allowed_high = v.nominal + v.tolerance;
        const bool inside = low >= allowed_low && high <= allowed_high;
        const bool disjoint = high < allowed_low || low > allowed_high;
        EXPECT_EQ(v.verdict == mic::Verdict::kWithin, inside) << seed << " " << v.parameter;
        EXPECT_EQ(v.verdict == mic::Verdict::kOutside, disjoint) << seed << " " << v.parameter;
        undecided |= v.verdict == mic::Verdict::kUndecided;
        if (v.verdict == mic::Verdict::kUndecided) EXPECT_GT(v.record_needed_s, 12 * 3600.0) << v.parameter;
        else EXPECT_TRUE(std::isnan(v.record_needed_s)) << v.parameter;
      }
      EXPECT_EQ(w.narrowing.measured(), undecided) << w.narrowing.text;
      if (w.narrowing.measured()) {
        // Stationary signal and noise: the half-width goes as 1 / sqrt(length). The bound is
        // the sub-windows' own scatter, which their few cells make about 0.1.
        EXPECT_NEAR(w.narrowing.exponent, 0.5, 0.2) << w.narrowing.text;
        EXPECT_EQ(w.narrowing.sub_windows, 6) << w.narrowing.text;
      }
    }
  }
}

TEST(ToleranceVerdict, GroupsTakeTheirWorstVerdict) {
  std::vector<mic::ToleranceVerdict> v(9);
  const char* names[9] = {"scale_x", "scale_y", "scale_z", "nonorthogonality_xy", "nonorthogonality_xz",
                          "nonorthogonality_yz", "misalignment_x", "misalignment_y", "misalignment_z"};
  for (int k = 0; k < 9; ++k) {
    v[k].parameter = names[k];
    v[k].verdict = mic::Verdict::kWithin;
  }
  v[2].verdict = mic::Verdict::kUndecided;
  v[2].record_needed_s = 3.0 * 86400.0;
  v[4].verdict = mic::Verdict::kOutside;
  v[5].verdict = mic::Verdict::kUndecided;
  const auto groups = mic::group_verdicts(v);
  ASSERT_EQ(groups.size(), 3u);
  EXPECT_EQ(groups[0].worst, mic::Verdict::kUndecided);
  EXPECT_EQ(groups[0].text, "undecided: z (record 3.0 days); within: x, y");
  EXPECT_EQ(groups[1].worst, mic::Verdict::kOutside);
  EXPECT_EQ(groups[1].text, "outside: xz; undecided: yz; within: xy");
  EXPECT_EQ(groups[2].worst, mic::Verdict::kWithin);
  EXPECT_EQ(groups[2].text, "within: x, y, z");
}
