// Known-truth tests of the test-only disturbances (unmodelled_disturbances.hpp) and of the
// remote observatory's coherence with the pair (remote_observatory.hpp): the expected values come
// from the physics of each model (filter response, random-walk variance, thermostat cycle, the
// remote's own share of the field), not from the code.
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/simulation/hut_temperature.hpp"
#include "magnetometer_insitu_calibration/simulation/remote_observatory.hpp"
#include "magnetometer_insitu_calibration/simulation/unmodelled_disturbances.hpp"
#include "simulator_test_helpers.hpp"
#include "test_constants.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <functional>
#include <limits>
#include <utility>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

using mic::test::quiet_settings;

using magnetometer_insitu_calibration::test::kPi;

/// Amplitude and phase (rad) of the harmonic k of x (N samples), from a direct DFT sum.
std::complex<double> harmonic(const Eigen::VectorXd& x, int k) {
  std::complex<double> sum = 0.0;
  const double n = static_cast<double>(x.size());
  for (Eigen::Index i = 0; i < x.size(); ++i) sum += x(i) * std::polar(1.0, -2.0 * kPi * k * static_cast<double>(i) / n);
  return 2.0 * sum / n;
}

}  // namespace

TEST(TestResponse, OnePoleLowPassAndDelayOfASinusoid) {
  // 4096 samples at 1 s; a sinusoid of 40 whole cycles (f = 40/4096 Hz) in each component.
  const int n = 4096, cycles = 40;
  const double dt = 1.0, f = cycles / (n * dt), corner = 0.02, delay = 3.0;
  mic::Readings x(n, 3);
  for (int i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) x(i, c) = (c + 1.0) * std::cos(2.0 * kPi * f * i * dt + c);
  const mic::Readings before = x;
  mic::apply_test_response(x, dt, corner, delay);
  // H(f) = e^{-2 pi i f delay} / (1 + i f / corner).
  const std::complex<double> h = std::polar(1.0, -2.0 * kPi * f * delay) / std::complex<double>(1.0, f / corner);
  for (int c = 0; c < 3; ++c) {
    const std::complex<double> in = harmonic(before.col(c), cycles), out = harmonic(x.col(c), cycles);
    // Not 1e-12: the line through the end samples (removed before the transform) carries a
    // tiny share of the sinusoid, which goes through the group delay instead of H(f).
    EXPECT_NEAR(std::abs(out / in), std::abs(h), 2e-3) << c;
    EXPECT_NEAR(std::arg(out / in), std::arg(h), 2e-3) << c;
  }
}

TEST(TestResponse, RampIsDelayedByTheGroupDelayAndNaNRunsStay) {
  const int n = 2000;
  const double dt = 1.0, corner = 0.05, delay = 2.0, slope = 0.01;  // nT/s
  mic::Readings x(n, 3);
  for (int i = 0; i < n; ++i) x.row(i).setConstant(100.0 + slope * i * dt);
  x.block(500, 1, 30, 1).setConstant(std::nan(""));
  mic::apply_test_response(x, dt, corner, delay);
  // A ramp through H: the ramp delayed by delay + 1 / (2 pi corner) (low-frequency group delay).
  const double shift = delay + 1.0 / (2.0 * kPi * corner);
  for (int i : {100, 1000, 1900}) EXPECT_NEAR(x(i, 0), 100.0 + slope * (i * dt - shift), 1e-9) << i;
  for (int i = 500; i < 530; ++i) EXPECT_TRUE(std::isnan(x(i, 1))) << i;
  EXPECT_TRUE(std::isfinite(x(499, 1)) && std::isfinite(x(530, 1)));
}

TEST(UnmodelledDisturbances, ReferenceUntouchedAndNothingAddedWhenOff) {
  mic::SimulationSettings s = quiet_settings();
  s.duration_s = 20000.0;
  const mic::SimulatedPair clean = mic::simulate_pair(s);
  mic::SimulatedPair pair = clean;
  mic::add_unmodelled_disturbances(pair, mic::UnmodelledDisturbanceSettings{});
  EXPECT_EQ((pair.test.values_nT - clean.test.values_nT).cwiseAbs().maxCoeff(), 0.0);
  mic::UnmodelledDisturbanceSettings u;
  u.tilt_walk_nT_per_sqrt_day = 1.0;
  u.heater_nT = Eigen::Vector3d(0.1, 0.0, -0.1);
  u.test_corner_hz = 0.1;
  u.test_delay_s = 0.5;
  mic::add_unmodelled_disturbances(pair, u);
  EXPECT_EQ((pair.reference.values_nT - clean.reference.values_nT).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_GT((pair.test.values_nT - clean.test.values_nT).cwiseAbs().maxCoeff(), 0.01);
}

TEST(UnmodelledDisturbances, TiltWalkVarianceGrowsAsSetAndActsThroughTheField) {
  // Variance of each tilt angle after t days: (walk / |B|)^2 t, B the constant main field.
  const double walk = 0.5, days = 0.25;
  mic::SimulationSettings s = quiet_settings();
  s.duration_s = days * 86400.0;
  s.variation_rms_nT = 0.0;
  s.daily_amplitude_nT.setZero();
  const mic::SimulatedPair clean = mic::simulate_pair(s);
  const double b = s.main_field_nT.norm();
  double sum2 = 0.0;
  const int seeds = 200;
  for (int k = 0; k < seeds; ++k) {
    mic::SimulatedPair pair = clean;
    mic::UnmodelledDisturbanceSettings u;
    u.seed = 100 + static_cast<std::uint64_t>(k);
    u.tilt_walk_nT_per_sqrt_day = walk;
    const mic::UnmodelledDisturbanceReport r = mic::add_unmodelled_disturbances(pair, u);
    sum2 += r.tilt_end_rad.squaredNorm();
    if (k == 0) {
      // Last sample: B [theta]x n_true with theta = (theta_x, theta_y, 0).
      const Eigen::Vector2d t = r.tilt_end_rad;
      Eigen::Matrix3d cross;
      cross << 0, 0, t(1), 0, 0, -t(0), -t(1), t(0), 0;
      const Eigen::RowVector3d expected = s.main_field_nT.transpose() * cross * clean.n_true;
      const Eigen::Index last = static_cast<Eigen::Index>(pair.test.size()) - 1;
      EXPECT_LT((pair.test.values_nT.row(last) - clean.test.values_nT.row(last) - expected).norm(), 1e-6);
    }
  }
  const double expected_var = (walk / b) * (walk / b) * days;
  // 400 squared Gaussians: relative standard error of the mean sqrt(2 / 400) = 7 %.
  EXPECT_NEAR(sum2 / (2.0 * seeds) / expected_var, 1.0, 0.25);
}

TEST(UnmodelledDisturbances, HeaterCyclesWithSetPeriodDutyAndLevel) {
  mic::SimulationSettings s = quiet_settings();
  s.duration_s = 86400.0;
  mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::UnmodelledDisturbanceSettings u;
  u.heater_nT = Eigen::Vector3d(0.0, 0.05, 0.0);
  u.heater_period_s = 1800.0;
  u.heater_duty = 0.4;
  u.heater_time_constant_s = 30.0;
  const mic::UnmodelledDisturbanceReport r = mic::add_unmodelled_disturbances(pair, u);
  // 48 cycles of 1800 +- 20 % s in a day (plus the one cut at the start).
  EXPECT_NEAR(static_cast<double>(r.heater_cycles), 49.0, 6.0);
  const Eigen::VectorXd y = r.heater_added_nT.col(1);
  EXPECT_LE(y.maxCoeff(), 0.05 + 1e-12);
  EXPECT_GT(y.maxCoeff(), 0.0499);  // on for ~720 s >> 30 s
  EXPECT_GE(y.minCoeff(), 0.0);
  EXPECT_LT(y.minCoeff(), 1e-4);
  EXPECT_NEAR(y.mean() / 0.05, 0.4, 0.03);  // duty
  EXPECT_EQ(r.heater_added_nT.col(0).cwiseAbs().maxCoeff(), 0.0);
}

TEST(UnmodelledDisturbances, SpikesOfTheTestStayUnfiltered) {
  mic::SimulationSettings s = quiet_settings();
  s.duration_s = 20000.0;
  s.spikes_per_day = 100.0;
  s.spike_instrument = mic::SimulatedInstrument::kTest;
  mic::SimulatedPair pair = mic::simulate_pair(s);
  const mic::Readings before = pair.test.values_nT;
  mic::UnmodelledDisturbanceSettings u;
  u.test_corner_hz = 0.05;
  mic::add_unmodelled_disturbances(pair, u);
  ASSERT_FALSE(pair.spikes.empty());
  for (const mic::SimulatedSpike& spike : pair.spikes) {
    const Eigen::Index i = static_cast<Eigen::Index>(spike.index);
    // The field (~0.01 nT/s at most here) moves little through the filter; the spike is whole.
    EXPECT_NEAR(pair.test.values_nT(i, spike.component), before(i, spike.component), 1.0) << spike.index;
    if (i + 1 < static_cast<Eigen::Index>(pair.test.size()))
      EXPECT_NEAR(pair.test.values_nT(i + 1, spike.component), before(i + 1, spike.component), 1.0);
  }
}

TEST(UnmodelledDisturbances, RejectsImpossibleSettingsNamingTheField) {
  auto where = [](const mic::UnmodelledDisturbanceSettings& u) {
    try {
      u.validate();
    } catch (const mic::InputError& e) {
      return e.where();
    }
    return std::string("none");
  };
  mic::UnmodelledDisturbanceSettings u;
  EXPECT_EQ(where(u), "none");
  u.test_corner_hz = -1.0;
  EXPECT_EQ(where(u), "test_corner_hz");
  u = {};
  u.tilt_walk_nT_per_sqrt_day = NAN;
  EXPECT_EQ(where(u), "tilt_walk_nT_per_sqrt_day");
  u = {};
  u.heater_duty = 1.0;
  EXPECT_EQ(where(u), "heater_duty");
  u = {};
  u.heater_period_s = 0.0;
  EXPECT_EQ(where(u), "heater_period_s");
}

// ---- Hut temperature (hut_temperature.hpp) ----------------------------------------------------

namespace {
mic::SimulationSettings quiet_for(double duration_s) {
  mic::SimulationSettings s = quiet_settings();
  s.duration_s = duration_s;
  return s;
}
}  // namespace

TEST(HutTemperature, DailyCycleChangesScaleAndOffsetByTheStatedCoefficients) {
  mic::SimulationSettings sim = quiet_for(2 * 86400.0);
  sim.gap_count = 1;
  sim.gap_length_s = 60.0;
  sim.gap_instrument = mic::SimulatedInstrument::kTest;
  mic::SimulatedPair pair = mic::simulate_pair(sim);
  const mic::Readings before = pair.test.values_nT;
  mic::HutTemperatureSettings hut;
  hut.heater_amplitude_C = 0.0;
  hut.thermometer_noise_C = 0.0;
  hut.mean_C = 18.0;
  hut.reference_C = 20.0;
  const mic::HutTemperatureReport report = mic::add_hut_temperature(pair, hut);
  ASSERT_EQ(report.temperature_C.size(), pair.test.size());
  ASSERT_EQ(pair.test.auxiliary.size(), 1u);
  const mic::AuxiliaryChannel& reading = pair.test.auxiliary[0];
  EXPECT_EQ(reading.name, "sensor_temperature");
  EXPECT_EQ(reading.unit, "degC");
  std::size_t nan_readings = 0;
  for (std::size_t i = 0; i < pair.test.size(); ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    const double t = pair.test.time_s[i];
    // 2025-05-14 starts at 00:00 UTC: the maximum at 14:00 UTC each day.
    const double theta = 18.0 + 3.0 * std::cos(2.0 * kPi * (std::fmod(t, 86400.0) - 14.0 * 3600.0) / 86400.0);
    ASSERT_NEAR(report.temperature_C[i], theta, 1e-9) << i;
    const double d = theta - 20.0;
    if (!before.row(row).allFinite()) {
      EXPECT_TRUE(std::isnan(reading.values[i])) << "a reading without its packet at " << i;
      ++nan_readings;
      continue;
    }
    EXPECT_NEAR(reading.values[i], std::round(theta * 100.0) / 100.0, 1e-9) << i;  // 0.01 deg C steps
    const Eigen::Vector3d scale(15e-6, -10e-6, 25e-6), offset(0.2, -0.15, 0.3);
    for (int l = 0; l < 3; ++l) {
      ASSERT_NEAR(pair.test.values_nT(row, l), before(row, l) * (1.0 + scale(l) * d) + offset(l) * d, 1e-8) << i << " " << l;
    }
  }
  EXPECT_EQ(nan_readings, 60u);
  // At 14:00 UTC the sensor is 1 deg C above reference: Z (43000 nT) reads 25 ppm x 43000 + 0.3 nT more.
  const auto peak = static_cast<Eigen::Index>(14 * 3600);
  EXPECT_NEAR(pair.test.values_nT(peak, 2) - before(peak, 2), 25e-6 * before(peak, 2) + 0.3, 1e-6);
}

TEST(HutTemperature, HeaterCyclesAreTrianglesOfTheStatedSizePeriodAndDuty) {
  mic::SimulationSettings sim = quiet_for(86400.0);
  mic::SimulatedPair pair = mic::simulate_pair(sim);
  mic::HutTemperatureSettings hut;
  hut.daily_amplitude_C = 0.0;
  hut.heater_amplitude_C = 0.4;
  hut.heater_period_s = 1200.0;
  hut.heater_period_jitter = 0.25;
  hut.heater_duty = 0.3;
  hut.seed = 5;
  const mic::HutTemperatureReport report = mic::add_hut_temperature(pair, hut);
  // 86400 s / 1200 s = 72 cycles on average; lengths uniform in 900..1500 s.
  EXPECT_GE(report.heater_cycles, 57u);
  EXPECT_LE(report.heater_cycles, 96u);
  double lo = 1e9, hi = -1e9;
  std::size_t warming = 0;
  for (std::size_t i = 0; i < report.temperature_C.size(); ++i) {
    lo = std::min(lo, report.temperature_C[i]);
    hi = std::max(hi, report.temperature_C[i]);
    if (i > 0) warming += report.temperature_C[i] > report.temperature_C[i - 1];
  }
  EXPECT_GE(lo, 20.0 - 0.4 - 1e-12);
  EXPECT_LE(hi, 20.0 + 0.4 + 1e-12);
  EXPECT_LT(lo, 20.0 - 0.39);  // every cycle reaches its extremes
  EXPECT_GT(hi, 20.0 + 0.39);
  EXPECT_NEAR(static_cast<double>(warming) / static_cast<double>(report.temperature_C.size()), 0.3, 0.02);
  // The thermometer adds 0.005 deg C rms and rounds to 0.01 deg C.
  double sum2 = 0.0;
  const auto& reading = pair.test.auxiliary.at(0).values;
  for (std::size_t i = 0; i < reading.size(); ++i) sum2 += std::pow(reading[i] - report.temperature_C[i], 2);
  EXPECT_NEAR(std::sqrt(sum2 / static_cast<double>(reading.size())), std::sqrt(0.005 * 0.005 + 0.01 * 0.01 / 12.0), 0.0007);
}

TEST(HutTemperature, ImpossibleSettingsNameTheField) {
  mic::SimulatedPair pair = mic::simulate_pair(quiet_for(600.0));
  auto field_of = [&](const mic::HutTemperatureSettings& s) -> std::string {
    try {
      mic::add_hut_temperature(pair, s);
    } catch (const mic::InputError& error) {
      return error.where();
    }
    return "";
  };
  mic::HutTemperatureSettings s;
  s.heater_duty = 1.0;
  EXPECT_EQ(field_of(s), "heater_duty");
  s = {};
  s.daily_amplitude_C = -1.0;
  EXPECT_EQ(field_of(s), "daily_amplitude_C");
  s = {};
  s.scale_ppm_per_C(1) = std::nan("");
  EXPECT_EQ(field_of(s), "scale_ppm_per_C");
  s = {};
  s.thermometer_resolution_C = -0.01;
  EXPECT_EQ(field_of(s), "thermometer_resolution_C");
  EXPECT_TRUE(pair.test.auxiliary.empty()) << "a refused setting changed the record";
}

namespace {

/// Over the harmonics of [low_hz, high_hz), the remote's component c regressed on the pair's field
/// (records of one length, sample period dt): Re(sum R X*) / sum |X|^2, and what the mixing
/// weight sqrt(1 - share(nu)) averages to over the field's power there, sum w |X|^2 / sum |X|^2.
/// Their difference is the remote's own field's chance correlation with the pair's over the band.
std::pair<double, double> band_weight(const mic::Readings& remote, const mic::Readings& field, int c, double dt,
                                      double low_hz, double high_hz, const std::function<double(double)>& share) {
  const auto r = mic::test::dft(remote.col(c)), x = mic::test::dft(field.col(c));
  const double duration = static_cast<double>(field.rows()) * dt;
  double cross = 0.0, power = 0.0, expected = 0.0;
  for (std::size_t k = 1; k < x.size(); ++k) {
    const double f = static_cast<double>(k) / duration;
    if (f < low_hz || f >= high_hz) continue;
    cross += std::real(r[k] * std::conj(x[k]));
    power += std::norm(x[k]);
    expected += std::sqrt(1.0 - share(f)) * std::norm(x[k]);
  }
  return {cross / power, expected / power};
}

}  // namespace

// The remote observatory (remote_observatory.hpp) without noise and in the pair's axes: the
// pair's field enters it with the weight sqrt(1 - f(nu)), f its own share of the field, the same
// at every frequency by default and growing as 1 - (1 - f0) exp(-nu / corner) with
// coherence_corner_hz (the rest its own field, independent of the pair's); its vertical with a
// share of its own, z_incoherent_fraction, larger than the horizontals'.
TEST(RemoteObservatory, OwnShareOfTheFieldAtEachFrequency) {
  mic::SimulationSettings s = quiet_settings();
  s.duration_s = 86400.0;
  s.keep_clean_field = true;
  s.seed = 5;
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::RemoteObservatorySettings r;
  r.seed = 9;
  r.rotation_deg.setZero();
  r.gain.setOnes();
  r.z_from_x = 0.0;
  r.white_nT = r.pink_nT_per_sqrt_hz = 0.0;
  r.z_incoherent_fraction = 0.6;
  const Eigen::Vector3d f0(r.incoherent_fraction, r.incoherent_fraction, r.z_incoherent_fraction);  // 0.2, 0.2, 0.6
  // Below 0.002 Hz the simulated activity is too intermittent for a day's chance correlation of
  // the two fields to stay small (up to 0.13 on 8 seeds at 0.0005-0.005 Hz); in these bands it
  // stayed within 0.04 on the same seeds.
  const struct Band { double low_hz, high_hz; } low{0.002, 0.01}, high{0.04, 0.06};
  for (const double corner : {std::numeric_limits<double>::infinity(), 0.05}) {
    SCOPED_TRACE(corner);
    r.coherence_corner_hz = corner;
    const auto share = [&](int c, double f) {
      return 1.0 - (1.0 - f0(c)) * std::exp(std::isinf(corner) ? 0.0 : -f / corner);
    };
    const mic::Readings remote = mic::simulate_remote_observatory(s, pair, r).values_nT;
    for (const Band& band : {low, high}) {
      for (int c = 0; c < 3; ++c) {
        const auto [measured, expected] = band_weight(remote, pair.field_nT, c, s.sample_period_s, band.low_hz,
                                                      band.high_hz, [&](double f) { return share(c, f); });
        // x, y: 0.89 at every frequency by default; with the corner about 0.85 in the low band, 0.55
        // in the high. z: 0.63; with the corner about 0.6 and 0.4.
        EXPECT_NEAR(measured, expected, 0.06) << "component " << c << ", " << band.low_hz << "-" << band.high_hz << " Hz";
      }
    }
  }
  r.coherence_corner_hz = 0.0;
  EXPECT_THROW(mic::simulate_remote_observatory(s, pair, r), mic::InputError);
  r.coherence_corner_hz = 0.05;
  r.z_incoherent_fraction = 1.0;
  EXPECT_THROW(mic::simulate_remote_observatory(s, pair, r), mic::InputError);
}
