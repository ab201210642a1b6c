// Delay from the cross-spectral phase: simulated delays of 5 to 50 ms recovered within 1 ms; a
// delay removed from the whole window (advance_record) before the sections are cut.
#include "magnetometer_insitu_calibration/estimation/delay_estimation.hpp"
#include "magnetometer_insitu_calibration/estimation/robust/robust_estimator.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

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

// The robust estimator's whole-window Eq. 2 fits (n0, trend, the delay's spectra) are made on the
// records averaged in pairs of samples (pair_averages.hpp), an odd last sample left out: the
// delay keeps its value in seconds on even and odd windows alike.
TEST(DelayEstimation, TheWholeWindowFitsOnPairAveragesKeepTheDelay) {
  const mic::SimulatedPair pair = mic::simulate_pair(station(26, 0.030));
  for (const Eigen::Index rows : {Eigen::Index{86400}, Eigen::Index{86399}, Eigen::Index{43201}}) {
    mic::WindowEstimator estimator(mic::EstimatorSettings{});
    const mic::WindowEstimate e =
        estimator.estimate(pair.reference.values_nT.topRows(rows), pair.test.values_nT.topRows(rows), 1.0);
    ASSERT_EQ(e.quality, mic::Quality::kOk) << rows << ": " << e.quality_text;
    EXPECT_EQ(e.samples, static_cast<std::size_t>(rows)) << "the window's own samples, not the averages'";
    EXPECT_DOUBLE_EQ(e.sample_period_s, 1.0);
    EXPECT_NEAR(e.delay_s, 0.030, 0.003) << rows;  // a period or length mixed up would double or halve it
    EXPECT_LT(std::abs(e.delay_s - 0.030), 4.0 * e.delay_ci95_s / 1.96) << rows;
  }
}

TEST(DelayEstimation, UnrelatedRecordsGiveNoDelay) {
  const mic::SimulatedPair a = mic::simulate_pair(station(23, 0.0));
  const mic::SimulatedPair b = mic::simulate_pair(station(24, 0.0));
  const mic::DelayEstimate d = mic::estimate_delay(a.reference.values_nT, b.test.values_nT, a.n_true, 1.0);
  EXPECT_FALSE(d.ok) << d.text;
}

// advance_record: a sum of sines advanced by a fraction of a sample is the same sum at t + tau
// (away from the window's wrapped-around end), and a straight line is moved exactly.
TEST(AdvanceRecord, ShiftsBandLimitedSeriesAndLinesByAFractionOfASample) {
  const int n = 4096;
  const double dt = 1.0, tau = 2.37;
  mic::Readings x(n, 3);
  const auto field = [](double t, int k) {
    return 3.0 * std::sin(2.0 * M_PI * 0.0123 * t + k) + 0.5 * std::cos(2.0 * M_PI * 0.071 * t) + 0.002 * (k + 1) * t;
  };
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) x(i, k) = field(i * dt, k);
  const mic::Readings y = mic::advance_record(x, dt, tau);
  double worst = 0.0;
  for (int i = 200; i < n - 200; ++i)  // the ends take the wrap-around of a non-periodic window
    for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(y(i, k) - field(i * dt + tau, k)));
  EXPECT_LT(worst, 0.02);  // of 3.5 nT sines (leakage of non-integer periods)
  mic::Readings line(n, 3);
  for (int i = 0; i < n; ++i) line.row(i) = Eigen::RowVector3d(1.0, -2.0, 0.5) * i + Eigen::RowVector3d(7, 8, 9);
  const mic::Readings moved = mic::advance_record(line, dt, tau);
  for (int i = 0; i < n; i += 97)
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(moved(i, k), line(i, k) + tau * line(1, k) - tau * line(0, k), 1e-9);
  EXPECT_EQ(mic::advance_record(x, dt, 0.0), x);
}

// A test instrument 2 s late, no instrument noise: removing the delay from the whole window
// before the record is cut into sections leaves n nearly exact. The delay is not circular: the
// test is the same station's record cut 2 samples earlier. A phase shift of each 3-hour
// section's own DFT would take each section's wrapped-around ends for data.
TEST(DelayEstimation, RemovedDelayLeavesNoiseFreeScaleExact) {
  mic::SimulationSettings s = station(25, 0.0);
  s.reference_white_nT = s.test_white_nT = 0.0;
  s.reference_pink_nT_per_sqrt_hz = s.test_pink_nT_per_sqrt_hz = 0.0;
  s.duration_s = 2.0 * 86400.0 + 2.0;
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  const Eigen::Index n = pair.reference.values_nT.rows() - 2;
  const mic::Readings reference = pair.reference.values_nT.bottomRows(n);  // R(t) = B(t + 2 s)
  const mic::Readings test = pair.test.values_nT.topRows(n);               // T(t) = B(t) n: 2 s late
  mic::WindowEstimator estimator(mic::EstimatorSettings{});
  const mic::WindowEstimate e = estimator.estimate(reference, test, 1.0);
  ASSERT_EQ(e.quality, mic::Quality::kOk) << e.quality_text;
  EXPECT_NEAR(e.delay_s, 2.0, 0.001);
  ASSERT_TRUE(estimator.robust_diagnostics()->delay_corrected);
  const mic::CalibrationParameters truth = mic::decompose(pair.n_true);
  const double scale = (e.parameters.scale_ratio - truth.scale_ratio).cwiseAbs().maxCoeff();
  const double angle = (e.parameters.nonorthogonality_deg - truth.nonorthogonality_deg).cwiseAbs().maxCoeff();
  std::printf("noise-free, 2 s late: worst scale error %.2e, angle %.2e deg\n", scale, angle);
  EXPECT_LT(scale, 1e-6);  // measured 8e-10 (a phase shift per section: 5.2e-4)
  EXPECT_LT(angle, 1e-4);  // measured 3e-7 deg (per section: 0.022 deg)
}
