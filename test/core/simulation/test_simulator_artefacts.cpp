// Known-truth tests of the simulator's artefacts: drift, tilt of the test pier, delay, spikes
// and gaps.
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "simulator_test_helpers.hpp"
#include "test_constants.hpp"

#include <Eigen/QR>
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

using mic::test::dft;
using mic::test::quiet_settings;

using magnetometer_insitu_calibration::test::kPi;

Eigen::VectorXd linear_fit(const Eigen::VectorXd& x, const Eigen::VectorXd& y) {
  Eigen::MatrixXd a(x.size(), 2);
  a.col(0).setOnes();
  a.col(1) = x;
  return a.colPivHouseholderQr().solve(y);  // (intercept, slope)
}

Eigen::VectorXd days_since_start(const mic::VectorRecord& r) {
  Eigen::VectorXd d(static_cast<Eigen::Index>(r.size()));
  for (std::size_t i = 0; i < r.size(); ++i) d(static_cast<Eigen::Index>(i)) = (r.time_s[i] - r.time_s[0]) / 86400.0;
  return d;
}

}  // namespace

TEST(Simulator, DriftAppearsAsSetSlope) {
  mic::SimulationSettings s = quiet_settings();
  s.duration_s = 2 * 86400.0;
  s.drift_nT_per_day = Eigen::Vector3d(0.5, -1.2, 2.0);
  s.test_offset_nT = Eigen::Vector3d(10.0, -4.0, 3.0);
  const mic::SimulatedPair p = mic::simulate_pair(s);
  EXPECT_EQ(p.trend_nT_per_day, s.drift_nT_per_day);
  const mic::Readings d = p.test.values_nT - p.reference.values_nT * p.n_true;
  const Eigen::VectorXd days = days_since_start(p.test);
  for (int c = 0; c < 3; ++c) {
    const Eigen::VectorXd fit = linear_fit(days, d.col(c));
    EXPECT_NEAR(fit(1), s.drift_nT_per_day(c), 1e-9);
    EXPECT_NEAR(fit(0), s.test_offset_nT(c), 1e-9);
  }
}

TEST(Simulator, TiltDriftRotatesTheTestAxes) {
  mic::SimulationSettings s = quiet_settings();
  s.duration_s = 2 * 86400.0;
  s.tilt_axis = Eigen::Vector3d(0.0, 2.0, 0.0);
  s.tilt_rate_deg_per_day = 0.01;
  const mic::SimulatedPair p = mic::simulate_pair(s);
  // T_i = B_i n(t_i) exactly, with n(t_mid) = n_true.
  double worst = 0;
  for (std::size_t i = 0; i < p.test.size(); i += 997) {
    const Eigen::Index r = static_cast<Eigen::Index>(i);
    const Eigen::RowVector3d expected = p.field_nT.row(r) * p.n_at(p.test.time_s[i]);
    worst = std::max(worst, (p.test.values_nT.row(r) - expected).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 1e-9);
  EXPECT_LT((p.n_at(p.tilt_reference_time_s) - p.n_true).cwiseAbs().maxCoeff(), 1e-15);
  // Rotation of 0.01 deg/day about +y turns test axis x towards -z and z towards +x: through
  // the main field (21500, 500, 43000) nT the x reading drifts by -Z w and the z reading by
  // +X w (w = 1.745e-4 rad/day): -7.5 and +3.75 nT/day.
  const double w = 0.01 * kPi / 180.0;
  EXPECT_NEAR(p.tilt_trend_nT_per_day(0), -43000.0 * w, 43000.0 * w * 0.01);
  EXPECT_NEAR(p.tilt_trend_nT_per_day(1), 0.0, 0.01 * 43000.0 * w);
  EXPECT_NEAR(p.tilt_trend_nT_per_day(2), 21500.0 * w, 21500.0 * w * 0.01);
  const mic::Readings d = p.test.values_nT - p.reference.values_nT * p.n_true;
  const Eigen::VectorXd days = days_since_start(p.test);
  for (int c = 0; c < 3; ++c) {
    const double slope = linear_fit(days, d.col(c))(1);
    EXPECT_NEAR(slope, p.tilt_trend_nT_per_day(c), 0.02 + 0.01 * std::abs(p.tilt_trend_nT_per_day(c)));
  }
}

TEST(Simulator, DelayIsAnExactPhaseShift) {
  for (double dt : {1.0, 0.1}) {
    mic::SimulationSettings s = quiet_settings();
    s.sample_period_s = dt;
    // The daily variation is periodic in the record only for whole days: at 10 Hz a 3 h record
    // without it (the 1 Hz whole-day run checks that it is evaluated at t - delay).
    s.duration_s = dt == 1.0 ? 86400.0 : 3 * 3600.0;
    if (dt != 1.0) s.daily_amplitude_nT.setZero();
    s.delay_s = 0.020;
    const mic::SimulatedPair p = mic::simulate_pair(s);
    // The test instrument sees B(t - delay): T = B_delayed n_true.
    EXPECT_LT((p.test.values_nT - p.field_delayed_nT * p.n_true).cwiseAbs().maxCoeff(), 1e-9);
    const double n = static_cast<double>(p.field_nT.rows());
    const double df = 1.0 / (n * dt);
    for (int c = 0; c < 3; ++c) {
      // Without the main field (DC only): keeps the DFT rounding small.
      const auto x = dft(p.field_nT.col(c).array() - s.main_field_nT(c));
      const auto y = dft(p.field_delayed_nT.col(c).array() - s.main_field_nT(c));
      for (double f : {df, 3 * df, 0.001, 0.01, 0.1, 0.45 / dt}) {
        const std::size_t k = static_cast<std::size_t>(std::lround(f / df));
        const double fk = static_cast<double>(k) * df;
        const double phase = std::arg(std::conj(x[k]) * y[k]);  // cross-spectrum B, delayed B
        EXPECT_NEAR(phase, -2.0 * kPi * fk * s.delay_s, 1e-3) << "f " << fk << " dt " << dt;
        EXPECT_NEAR(std::abs(y[k]), std::abs(x[k]), 1e-9 * std::abs(x[k]) + 1e-9);
      }
    }
    // Sanity: the shift is visible in time (B changes by ~ dB/dt * delay, not zero).
    EXPECT_GT((p.field_delayed_nT - p.field_nT).cwiseAbs().maxCoeff(), 1e-6);
  }
}

TEST(Simulator, SpikesAndGapsCountedAsSet) {
  mic::SimulationSettings s;
  s.duration_s = 2 * 86400.0;
  s.spikes_per_day = 24.0;
  s.spike_amplitude_nT = 50.0;
  s.gap_count = 5;
  s.gap_length_s = 600.0;
  const mic::SimulatedPair p = mic::simulate_pair(s);
  mic::SimulationSettings clean_settings = s;
  clean_settings.spikes_per_day = 0.0;
  clean_settings.gap_count = 0;
  const mic::SimulatedPair clean = mic::simulate_pair(clean_settings);

  // Gaps: NaN runs of whole rows, each 600 samples, 5 in all over the two instruments.
  int runs = 0;
  std::size_t nan_rows = 0;
  for (const mic::Readings* v : {&p.reference.values_nT, &p.test.values_nT}) {
    bool in_run = false;
    std::size_t run_length = 0;
    for (Eigen::Index i = 0; i < v->rows(); ++i) {
      const bool nan_row = v->row(i).array().isNaN().all();
      EXPECT_EQ(nan_row, v->row(i).array().isNaN().any());  // whole rows only
      if (nan_row) {
        ++nan_rows;
        if (!in_run) ++runs;
        ++run_length;
      } else if (in_run) {
        EXPECT_EQ(run_length, 600u);
        run_length = 0;
      }
      in_run = nan_row;
    }
  }
  EXPECT_EQ(runs, 5);
  EXPECT_EQ(nan_rows, 5u * 600u);
  EXPECT_EQ(p.gaps.size(), 5u);

  // Spikes: exactly 48 samples differ from the spike-free run, each by +-50 nT in one component.
  int spikes = 0;
  for (int instrument = 0; instrument < 2; ++instrument) {
    const mic::Readings& v = instrument == 0 ? p.reference.values_nT : p.test.values_nT;
    const mic::Readings& w = instrument == 0 ? clean.reference.values_nT : clean.test.values_nT;
    for (Eigen::Index i = 0; i < v.rows(); ++i) {
      if (v.row(i).array().isNaN().any()) continue;
      for (int c = 0; c < 3; ++c) {
        const double d = v(i, c) - w(i, c);
        if (d != 0.0) {
          ++spikes;
          EXPECT_NEAR(std::abs(d), 50.0, 1e-9);
        }
      }
    }
  }
  EXPECT_EQ(spikes, 48);
  ASSERT_EQ(p.spikes.size(), 48u);
  int in_reference = 0;
  for (const auto& spike : p.spikes) {
    in_reference += spike.instrument == mic::SimulatedInstrument::kReference;
    const auto& v = spike.instrument == mic::SimulatedInstrument::kReference ? p.reference : p.test;
    const auto& w = spike.instrument == mic::SimulatedInstrument::kReference ? clean.reference : clean.test;
    const Eigen::Index r = static_cast<Eigen::Index>(spike.index);
    EXPECT_NEAR(v.values_nT(r, spike.component) - w.values_nT(r, spike.component), spike.amplitude_nT, 1e-9);
  }
  EXPECT_GT(in_reference, 0);  // "either": both instruments get some
  EXPECT_LT(in_reference, 48);
}

TEST(Simulator, GapsInBothInstrumentsCoincide) {
  mic::SimulationSettings s;
  s.duration_s = 86400.0;
  s.gap_count = 3;
  s.gap_length_s = 120.0;
  s.gap_instrument = mic::SimulatedInstrument::kBoth;
  s.spike_instrument = mic::SimulatedInstrument::kTest;
  s.spikes_per_day = 10;
  const mic::SimulatedPair p = mic::simulate_pair(s);
  ASSERT_EQ(p.gaps.size(), 3u);
  for (const auto& gap : p.gaps) {
    EXPECT_EQ(gap.instrument, mic::SimulatedInstrument::kBoth);
    EXPECT_EQ(gap.length, 120u);
    for (std::size_t i = gap.first_index; i < gap.first_index + gap.length; ++i) {
      EXPECT_TRUE(std::isnan(p.reference.values_nT(static_cast<Eigen::Index>(i), 0)));
      EXPECT_TRUE(std::isnan(p.test.values_nT(static_cast<Eigen::Index>(i), 2)));
    }
  }
  for (const auto& spike : p.spikes) EXPECT_EQ(spike.instrument, mic::SimulatedInstrument::kTest);
  EXPECT_EQ(p.reference.values_nT.array().isNaN().count(), 3 * 120 * 3);
}
