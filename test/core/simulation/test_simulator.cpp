// Known-truth tests of the two-instrument simulator.
#include "magnetometer_insitu_calibration/estimation/calibration_matrix.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/simulation/power_law_noise.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "magnetometer_insitu_calibration/formats/csv_record.hpp"
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "test_support.hpp"

#include <Eigen/QR>
#include <fftw3.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <fstream>
#include <cmath>
#include <complex>
#include <random>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

constexpr double kPi = 3.14159265358979323846;

// One-sided DFT X_k = sum_i x_i exp(-2 pi i k i / N), k = 0 .. N/2 (unnormalised).
std::vector<std::complex<double>> dft(const Eigen::VectorXd& x) {
  const int n = static_cast<int>(x.size());
  std::vector<double> in(x.data(), x.data() + n);
  std::vector<std::complex<double>> out(static_cast<std::size_t>(n / 2 + 1));
  fftw_plan plan = fftw_plan_dft_r2c_1d(n, in.data(), reinterpret_cast<fftw_complex*>(out.data()),
                                        FFTW_ESTIMATE);
  fftw_execute(plan);
  fftw_destroy_plan(plan);
  return out;
}

// Slope of log10(one-sided periodogram) against log10(f) over [f_low, f_high] Hz.
double log_log_slope(const Eigen::VectorXd& x, double dt, double f_low, double f_high) {
  const Eigen::VectorXd centred = x.array() - x.mean();
  const auto spectrum = dft(centred);
  const double df = 1.0 / (static_cast<double>(x.size()) * dt);
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  int count = 0;
  for (std::size_t k = 1; k < spectrum.size(); ++k) {
    const double f = static_cast<double>(k) * df;
    if (f < f_low || f > f_high) continue;
    const double lx = std::log10(f), ly = std::log10(std::norm(spectrum[k]));
    sx += lx; sy += ly; sxx += lx * lx; sxy += lx * ly;
    ++count;
  }
  return (count * sxy - sx * sy) / (count * sxx - sx * sx);
}

// A noise-free, artefact-free setting: T = B n_true exactly.
mic::SimulationSettings quiet_settings() {
  mic::SimulationSettings s;
  s.reference_white_nT = s.test_white_nT = 0.0;
  s.reference_pink_nT_per_sqrt_hz = s.test_pink_nT_per_sqrt_hz = 0.0;
  return s;
}

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

TEST(Simulator, NoiseFreeTestEqualsReferenceTimesN) {
  for (double dt : {1.0, 0.1}) {
    mic::SimulationSettings s = quiet_settings();
    s.sample_period_s = dt;
    s.duration_s = dt == 1.0 ? 86400.0 : 7200.0;
    const mic::SimulatedPair p = mic::simulate_pair(s);
    ASSERT_EQ(p.reference.size(), s.samples());
    ASSERT_EQ(p.test.size(), s.samples());
    EXPECT_DOUBLE_EQ(p.reference.time_s.front(), 1747180800.0);
    EXPECT_NEAR(p.reference.time_s[1] - p.reference.time_s[0], dt, 1e-6);
    EXPECT_LT((p.n_true - mic::matrix_from_angles(s.scale_ratio, s.nonorthogonality_deg,
                                                  s.misalignment_deg)).cwiseAbs().maxCoeff(), 0.0 + 1e-300);
    const mic::Readings residual = p.test.values_nT - p.reference.values_nT * p.n_true;
    EXPECT_LT(residual.cwiseAbs().maxCoeff(), 1e-9) << "dt " << dt;
    // The field is the main field plus variations: R really varies, and sits near main field.
    EXPECT_NEAR(p.reference.values_nT.col(2).mean(), 43000.0, 50.0);
    EXPECT_GT(p.reference.values_nT.col(0).maxCoeff() - p.reference.values_nT.col(0).minCoeff(), 10.0);
  }
}

TEST(Simulator, ExplicitMatrixIsUsed) {
  mic::SimulationSettings s = quiet_settings();
  s.duration_s = 3600.0;
  Eigen::Matrix3d n;
  n << 1.01, 0.002, -0.003, 0.001, 0.99, 0.004, 0.002, -0.001, 1.002;
  s.n_explicit = n;
  const mic::SimulatedPair p = mic::simulate_pair(s);
  EXPECT_EQ(p.n_true, n);
  EXPECT_LT((p.test.values_nT - p.reference.values_nT * n).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(Simulator, SpectralSlopeMatchesIndex) {
  for (double index : {1.0, 2.0, 2.7}) {
    mic::SimulationSettings s = quiet_settings();
    s.spectral_index = index;
    s.daily_amplitude_nT.setZero();
    s.seed = 11;
    const mic::SimulatedPair p = mic::simulate_pair(s);
    for (int c = 0; c < 3; ++c) {
      const double slope = log_log_slope(p.field_nT.col(c), s.sample_period_s, 0.001, 0.1);
      EXPECT_NEAR(slope, -index, 0.15) << "index " << index << " component " << c;
    }
  }
}

TEST(Simulator, VariationRmsAndCorrelationAsSet) {
  mic::SimulationSettings s = quiet_settings();
  s.daily_amplitude_nT.setZero();
  s.variation_rms_nT = 7.0;
  s.variation_z_ratio = 0.4;
  s.variation_correlation = Eigen::Vector3d(0.5, -0.3, 0.2);
  const mic::SimulatedPair p = mic::simulate_pair(s);
  const mic::Readings v = p.field_nT.rowwise() - s.main_field_nT.transpose();
  const double n = static_cast<double>(v.rows());
  const Eigen::Matrix3d cov = v.transpose() * v / n;
  EXPECT_NEAR(std::sqrt(cov(0, 0)), 7.0, 1e-9);
  EXPECT_NEAR(std::sqrt(cov(1, 1)), 7.0, 1e-9);
  EXPECT_NEAR(std::sqrt(cov(2, 2)), 2.8, 1e-9);
  EXPECT_NEAR(cov(0, 1) / std::sqrt(cov(0, 0) * cov(1, 1)), 0.5, 1e-9);
  EXPECT_NEAR(cov(0, 2) / std::sqrt(cov(0, 0) * cov(2, 2)), -0.3, 1e-9);
  EXPECT_NEAR(cov(1, 2) / std::sqrt(cov(1, 1) * cov(2, 2)), 0.2, 1e-9);
  EXPECT_LT(v.colwise().mean().cwiseAbs().maxCoeff(), 1e-9);  // zero-mean variations
}

TEST(Simulator, DailyVariationHasSetAmplitudeAndPeriods) {
  mic::SimulationSettings s = quiet_settings();
  s.variation_rms_nT = 0.0;
  s.daily_amplitude_nT = Eigen::Vector3d(20.0, 10.0, 6.0);
  s.daily_harmonic_weights = {1.0, 0.5, 0.25};
  const mic::SimulatedPair p = mic::simulate_pair(s);  // one whole UTC day
  for (int c = 0; c < 3; ++c) {
    const Eigen::VectorXd x = p.field_nT.col(c);
    const auto spectrum = dft(x);
    const double n = static_cast<double>(x.size());
    // Amplitude of harmonic k of a whole-day record: 2 |X_k| / N.
    EXPECT_NEAR(2.0 * std::abs(spectrum[1]) / n, s.daily_amplitude_nT(c), 1e-9);
    EXPECT_NEAR(2.0 * std::abs(spectrum[2]) / n, 0.5 * s.daily_amplitude_nT(c), 1e-9);
    EXPECT_NEAR(2.0 * std::abs(spectrum[3]) / n, 0.25 * s.daily_amplitude_nT(c), 1e-9);
    EXPECT_LT(2.0 * std::abs(spectrum[4]) / n, 1e-9);
    EXPECT_NEAR(x.mean(), s.main_field_nT(c), 1e-9);
  }
}

TEST(Simulator, InstrumentNoiseLevels) {
  mic::SimulationSettings s = quiet_settings();
  s.reference_white_nT = 0.05;
  s.test_white_nT = 0.2;
  const mic::SimulatedPair white = mic::simulate_pair(s);
  const mic::Readings dr = white.reference.values_nT - white.field_nT;
  const mic::Readings dt = white.test.values_nT - white.field_nT * white.n_true;
  for (int c = 0; c < 3; ++c) {
    const double n = static_cast<double>(dr.rows());
    EXPECT_NEAR(std::sqrt(dr.col(c).squaredNorm() / n), 0.05, 0.05 * 0.015);  // 6 sigma
    EXPECT_NEAR(std::sqrt(dt.col(c).squaredNorm() / n), 0.2, 0.2 * 0.015);
  }
  // Pink noise: one-sided PSD = level^2 / f. Mean of f * periodogram over 0.01-0.4 Hz
  // (~33000 harmonics, each chi-square 2 dof) is level^2 within 2 %.
  s = quiet_settings();
  s.test_pink_nT_per_sqrt_hz = 0.02;
  const mic::SimulatedPair pink = mic::simulate_pair(s);
  const mic::Readings noise = pink.test.values_nT - pink.field_nT * pink.n_true;
  EXPECT_LT((pink.reference.values_nT - pink.field_nT).cwiseAbs().maxCoeff(), 1e-12);
  for (int c = 0; c < 3; ++c) {
    const Eigen::VectorXd x = noise.col(c);
    const auto spectrum = dft(x);
    const double n = static_cast<double>(x.size()), df = 1.0 / n;
    double sum = 0;
    int count = 0;
    for (std::size_t k = 1; k < spectrum.size(); ++k) {
      const double f = static_cast<double>(k) * df;
      if (f < 0.01 || f > 0.4) continue;
      sum += f * 2.0 * s.sample_period_s / n * std::norm(spectrum[k]);
      ++count;
    }
    EXPECT_NEAR(sum / count, 0.02 * 0.02, 0.02 * 0.02 * 0.02) << "component " << c;
    EXPECT_NEAR(log_log_slope(x, 1.0, 0.001, 0.1), -1.0, 0.15);
  }
}

TEST(Simulator, DeterministicForSeedDifferentAcrossSeeds) {
  mic::SimulationSettings s;
  s.duration_s = 6 * 3600.0;
  s.spikes_per_day = 20;
  s.gap_count = 2;
  const mic::SimulatedPair a = mic::simulate_pair(s);
  const mic::SimulatedPair b = mic::simulate_pair(s);
  // Bitwise identical, NaN included (compare the bytes through a NaN-aware predicate).
  auto same = [](const mic::Readings& x, const mic::Readings& y) {
    return x.rows() == y.rows() &&
           ((x.array() == y.array()) || (x.array().isNaN() && y.array().isNaN())).all();
  };
  EXPECT_TRUE(same(a.reference.values_nT, b.reference.values_nT));
  EXPECT_TRUE(same(a.test.values_nT, b.test.values_nT));
  ASSERT_EQ(a.spikes.size(), b.spikes.size());
  for (std::size_t k = 0; k < a.spikes.size(); ++k) EXPECT_EQ(a.spikes[k].index, b.spikes[k].index);
  s.seed = 2;
  const mic::SimulatedPair c = mic::simulate_pair(s);
  EXPECT_FALSE(same(a.reference.values_nT, c.reference.values_nT));
  EXPECT_FALSE(same(a.test.values_nT, c.test.values_nT));
  // Different seeds give different variations, not a rescaled copy.
  const Eigen::VectorXd xa = a.field_nT.col(0).array() - a.field_nT.col(0).mean();
  const Eigen::VectorXd xc = c.field_nT.col(0).array() - c.field_nT.col(0).mean();
  EXPECT_LT(std::abs(xa.dot(xc)) / (xa.norm() * xc.norm()), 0.99);
}

TEST(Simulator, RandomNumbersArePortable) {
  // mt19937_64's sequence is fixed by the standard: its 10000th output from the default seed.
  std::mt19937_64 engine;
  engine.discard(9999);
  EXPECT_EQ(engine(), 9981545732273789042ULL);
  // Our normal transform: moments of 200000 draws.
  mic::SimulationRng rng(5, 0);
  double sum = 0, sum2 = 0, sum4 = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const double g = rng.normal();
    sum += g; sum2 += g * g; sum4 += g * g * g * g;
  }
  EXPECT_NEAR(sum / n, 0.0, 0.012);
  EXPECT_NEAR(sum2 / n, 1.0, 0.02);
  EXPECT_NEAR(sum4 / n, 3.0, 0.12);
  mic::SimulationRng other_stream(5, 1);
  mic::SimulationRng same_stream(5, 0);
  mic::SimulationRng first(5, 0);
  EXPECT_EQ(first.uniform(), same_stream.uniform());
  EXPECT_NE(mic::SimulationRng(5, 0).uniform(), other_stream.uniform());
}

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

TEST(Simulator, RejectsImpossibleSettingsNamingTheField) {
  auto where = [](const mic::SimulationSettings& s) -> std::string {
    try {
      mic::simulate_pair(s);
    } catch (const mic::InputError& e) {
      return e.where();
    }
    return "accepted";
  };
  mic::SimulationSettings s;
  s.sample_period_s = 0.0;
  EXPECT_EQ(where(s), "sample_period_s");
  s = {};
  s.duration_s = 5.0;
  EXPECT_EQ(where(s), "duration_s");
  s = {};
  s.variation_correlation = Eigen::Vector3d(0.99, 0.99, -0.99);
  EXPECT_EQ(where(s), "variation_correlation");
  s = {};
  s.scale_ratio(1) = -1.0;
  EXPECT_EQ(where(s), "scale_ratio");
  s = {};
  s.test_white_nT = -0.1;
  EXPECT_EQ(where(s), "test_white_nT");
  s = {};
  s.duration_s = 3600.0;
  s.gap_count = 10;
  s.gap_length_s = 600.0;
  EXPECT_EQ(where(s), "gap_count");
  s = {};
  s.spikes_per_day = 86400.0;
  EXPECT_EQ(where(s), "spikes_per_day");
  s = {};
  s.delay_s = NAN;
  EXPECT_EQ(where(s), "delay_s");
  s = {};
  s.n_explicit = Eigen::Matrix3d::Zero();
  EXPECT_EQ(where(s), "n_explicit");
}

TEST(Simulator, TruthJsonCarriesTheTruth) {
  mic::SimulationSettings s;
  s.duration_s = 3600.0;
  s.drift_nT_per_day = Eigen::Vector3d(1.0, 2.0, 3.0);
  s.spikes_per_day = 48;  // 2 spikes in an hour
  const mic::SimulatedPair p = mic::simulate_pair(s);
  const auto truth = nlohmann::json::parse(mic::simulation_truth_json(s, p));
  ASSERT_EQ(truth.at("n_true").size(), 9u);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(truth.at("n_true")[3 * r + c].get<double>(), p.n_true(r, c));
  EXPECT_EQ(truth.at("trend_nT_per_day")[2].get<double>(), 3.0);
  EXPECT_EQ(truth.at("spikes").size(), 2u);
  EXPECT_EQ(truth.at("settings").at("samples").get<std::size_t>(), 3600u);
  EXPECT_EQ(truth.at("settings").at("scale_ratio")[0].get<double>(), 0.9996);
  EXPECT_EQ(truth.at("settings").at("seed").get<std::uint64_t>(), 1u);
}

TEST(Simulator, FiveDaysAtOneHertzIsFast) {
  mic::SimulationSettings s;
  s.duration_s = 5 * 86400.0;
  s.spikes_per_day = 10;
  s.gap_count = 3;
  const auto start = std::chrono::steady_clock::now();
  const mic::SimulatedPair p = mic::simulate_pair(s);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(p.test.size(), 432000u);
  // Well under a second on one core; the bound leaves room for a loaded CI machine.
  EXPECT_LT(seconds, 3.0);
  RecordProperty("seconds", std::to_string(seconds));
}

// --- simulate_records, run as a user runs it ---------------------------------------------------
// Needs the executable's path from the build (SIMULATE_RECORDS_BIN="$<TARGET_FILE:simulate_records>").
#ifdef SIMULATE_RECORDS_BIN
namespace {
using mic::test::ProgramRun;
ProgramRun run_simulate_records(const std::string& args) {
  return mic::test::run_program(SIMULATE_RECORDS_BIN, args);
}
}  // namespace
#endif

TEST(SimulateRecordsCli, WritesRecordsAndTruthMatchingTheLibrary) {
#ifndef SIMULATE_RECORDS_BIN
  GTEST_SKIP() << "SIMULATE_RECORDS_BIN not defined by the build";
#else
  const std::string dir = mic::test::make_temp_dir("simulate_records");
  const ProgramRun r = run_simulate_records(
      "--out-dir " + dir + " --format csv --days 0.25 --rate 1 --seed 9 --scale 0.999,1.001,1.002 "
      "--nonorthogonality-deg 0.1,0,-0.05 --misalignment-deg 0.2,0.1,-0.3 --noise-nT 0.02,0.03 "
      "--drift-nT-per-day 1,-2,3 --spikes-per-day 8 --gaps 2 --gap-seconds 60 --delay-s 0.02 "
      "--decimals 6");
  ASSERT_EQ(r.status, 0) << r.output;
  mic::SimulationSettings s;
  s.duration_s = 0.25 * 86400.0;
  s.seed = 9;
  s.scale_ratio = Eigen::Vector3d(0.999, 1.001, 1.002);
  s.nonorthogonality_deg = Eigen::Vector3d(0.1, 0.0, -0.05);
  s.misalignment_deg = Eigen::Vector3d(0.2, 0.1, -0.3);
  s.reference_white_nT = 0.02;
  s.test_white_nT = 0.03;
  s.drift_nT_per_day = Eigen::Vector3d(1, -2, 3);
  s.spikes_per_day = 8;
  s.gap_count = 2;
  s.gap_length_s = 60;
  s.delay_s = 0.02;
  const mic::SimulatedPair expected = mic::simulate_pair(s);
  const mic::VectorRecord reference = mic::read_csv_record(dir + "/reference.csv");
  const mic::VectorRecord test = mic::read_csv_record(dir + "/test.csv");
  ASSERT_EQ(reference.size(), expected.reference.size());
  ASSERT_EQ(test.size(), expected.test.size());
  EXPECT_NEAR(test.time_s.back(), expected.test.time_s.back(), 1e-6);
  for (Eigen::Index i = 0; i < test.values_nT.rows(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const double a = test.values_nT(i, c), b = expected.test.values_nT(i, c);
      ASSERT_EQ(std::isnan(a), std::isnan(b)) << "row " << i;
      if (!std::isnan(a)) ASSERT_NEAR(a, b, 6e-7) << "row " << i;
      const double ar = reference.values_nT(i, c), br = expected.reference.values_nT(i, c);
      ASSERT_EQ(std::isnan(ar), std::isnan(br)) << "row " << i;
      if (!std::isnan(ar)) ASSERT_NEAR(ar, br, 6e-7) << "row " << i;
    }
  }
  std::ifstream in(dir + "/truth.json");
  const nlohmann::json truth = nlohmann::json::parse(in);
  for (int k = 0; k < 9; ++k) EXPECT_EQ(truth["n_true"][k].get<double>(), expected.n_true(k / 3, k % 3));
  EXPECT_EQ(truth["trend_nT_per_day"][1].get<double>(), -2.0);
  EXPECT_EQ(truth["spikes"].size(), 2u);
  EXPECT_EQ(truth["gaps"].size(), 2u);
  EXPECT_EQ(truth["settings"]["delay_s"].get<double>(), 0.02);

  // IAGA-2002: values at 0.01 nT.
  const ProgramRun iaga = run_simulate_records("--out-dir " + dir + "/iaga --days 0.05 --seed 9");
  ASSERT_EQ(iaga.status, 0) << iaga.output;
  const mic::VectorRecord ref_iaga = mic::read_iaga2002(dir + "/iaga/reference.iaga");
  EXPECT_EQ(ref_iaga.size(), 4320u);
  EXPECT_EQ(ref_iaga.station, "SIM");
#endif
}

TEST(SimulateRecordsCli, BadOptionsAreNamedAndFail) {
#ifndef SIMULATE_RECORDS_BIN
  GTEST_SKIP() << "SIMULATE_RECORDS_BIN not defined by the build";
#else
  const std::string dir = mic::test::make_temp_dir("simulate_records_bad");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--format xml", "--format"},
      {"--scale 1,2", "--scale"},
      {"--noise-nT 0.1,x", "--noise-nT"},
      {"--rate 0", "--rate"},
      {"--gaps 100 --gap-seconds 3600", "--gaps"},
      {"--nonorthogonality-deg 89,89,-89", "--nonorthogonality-deg"},
      {"--delay-s 1e9", "--delay-s"},
  };
  for (const auto& [args, option] : cases) {
    const ProgramRun r = run_simulate_records("--out-dir " + dir + " " + args);
    EXPECT_NE(r.status, 0) << args;
    EXPECT_NE(r.output.find(option), std::string::npos) << args << " -> " << r.output;
  }
#endif
}
