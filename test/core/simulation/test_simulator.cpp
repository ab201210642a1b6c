// Known-truth tests of the two-instrument simulator: the field, the matrix and the instrument
// noise, determinism, settings validation, the truth JSON and speed. Artefacts (drift, tilt,
// delay, spikes, gaps): test_simulator_artefacts.cpp; the program: test_simulate_records_cli.cpp.
#include "magnetometer_insitu_calibration/estimation/calibration_matrix.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/simulation/power_law_noise.hpp"
#include "magnetometer_insitu_calibration/simulation/lemi025_station.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "simulator_test_helpers.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <complex>
#include <random>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

using mic::test::dft;
using mic::test::quiet_settings;

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

// Two stations with one field_seed and their own seeds: one field, bit for bit, through
// independent noise (the simulated network's remote reference); field_seed equal to the seed
// changes nothing.
TEST(Simulator, AFieldSeedSharesTheFieldAndNotTheNoise) {
  mic::SimulationSettings s;
  s.duration_s = 6 * 3600.0;
  s.seed = 1;
  const mic::SimulatedPair a = mic::simulate_pair(s);
  s.field_seed = 1;
  const mic::SimulatedPair a_again = mic::simulate_pair(s);
  EXPECT_TRUE((a.reference.values_nT.array() == a_again.reference.values_nT.array()).all());
  s.seed = 2;
  const mic::SimulatedPair b = mic::simulate_pair(s);
  EXPECT_TRUE((a.field_nT.array() == b.field_nT.array()).all()) << "not one field";
  const mic::Readings noise_a = a.reference.values_nT - a.field_nT;
  const mic::Readings noise_b = b.reference.values_nT - b.field_nT;
  for (int c = 0; c < 3; ++c) {
    const Eigen::VectorXd x = noise_a.col(c).array() - noise_a.col(c).mean();
    const Eigen::VectorXd y = noise_b.col(c).array() - noise_b.col(c).mean();
    EXPECT_GT(x.norm(), 0.0);
    // Independent noises: correlation within a few 1/sqrt(N) (N = 21600; the 1/f part has
    // fewer independent values, hence 0.1).
    EXPECT_LT(std::abs(x.dot(y)) / (x.norm() * y.norm()), 0.1) << "component " << c;
  }
}

// The simulated LEMI-025 station's time base, as the vendor's packets have it: readings at
// 10 Hz, the first 0.3 s before the first packet's GPS second; a live record from the hour.
TEST(Simulator, Lemi025StationSettings) {
  mic::SimulationSettings base;
  base.seed = 7;
  base.field_seed = 3;
  const mic::SimulationSettings s = mic::lemi025_station_settings(base, 1747180800.0, 1619.2, 4.0);
  EXPECT_EQ(s.seed, 7u);
  EXPECT_EQ(s.field_seed, 3u);
  EXPECT_DOUBLE_EQ(s.start_time_s, 1747180800.0 - 0.3);
  EXPECT_DOUBLE_EQ(s.duration_s, 1620.0);
  EXPECT_DOUBLE_EQ(s.sample_period_s, 0.1);
  EXPECT_DOUBLE_EQ(s.variation_rms_nT, 4.0);
  EXPECT_DOUBLE_EQ(mic::lemi025_live_start_s(1747184399.9), 1747180800.0);  // 00:59:59.9 -> 00:00
  EXPECT_DOUBLE_EQ(mic::lemi025_live_start_s(1747184400.0), 1747184400.0);
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
