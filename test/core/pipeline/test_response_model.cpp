// The response model (estimation/response_model.hpp) and its use by the pipeline: a test
// instrument behind a 1-pole low-pass at 0.03 Hz and a 2 s delay (the reference flat), known n.
#include "magnetometer_insitu_calibration/estimation/response_model.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "test_constants.hpp"

#include <fftw3.h>
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <vector>
#include <cstdio>
#include <random>

namespace mic = magnetometer_insitu_calibration;

namespace {

using magnetometer_insitu_calibration::test::kPi;

/// An analogue first-order low-pass 1 / (1 + i f / fc) and a delay exp(-i 2 pi f delay_s), applied
/// exactly in the frequency domain at dt = 1 s (fc = 0: no filter). The line through the end samples
/// is taken out first so the circular transform sees no step, and put back as the filter passes a
/// line: a + b t -> a + b (t - delay_s - 1 / (2 pi fc)).
mic::Readings low_pass(const mic::Readings& x, double corner_hz, double delay_s) {
  const auto n = static_cast<std::size_t>(x.rows());
  mic::Readings y = x;
  std::vector<double> buffer(n);
  std::vector<fftw_complex> spectrum(n / 2 + 1);
  const fftw_plan forward = fftw_plan_dft_r2c_1d(static_cast<int>(n), buffer.data(), spectrum.data(), FFTW_ESTIMATE);
  const fftw_plan backward = fftw_plan_dft_c2r_1d(static_cast<int>(n), spectrum.data(), buffer.data(), FFTW_ESTIMATE);
  const double lag = delay_s + (corner_hz > 0.0 ? 1.0 / (2.0 * kPi * corner_hz) : 0.0);
  for (int c = 0; c < 3; ++c) {
    const double first = x(0, c), slope = (x(x.rows() - 1, c) - first) / static_cast<double>(n - 1);
    for (std::size_t i = 0; i < n; ++i) buffer[i] = x(static_cast<Eigen::Index>(i), c) - first - slope * static_cast<double>(i);
    fftw_execute(forward);
    for (std::size_t j = 0; j <= n / 2; ++j) {
      const double f = static_cast<double>(j) / static_cast<double>(n);
      std::complex<double> h = std::exp(std::complex<double>(0.0, -2.0 * kPi * f * delay_s));
      if (corner_hz > 0.0) h /= std::complex<double>(1.0, f / corner_hz);
      const std::complex<double> v = std::complex<double>(spectrum[j][0], spectrum[j][1]) * h / static_cast<double>(n);
      spectrum[j][0] = v.real();
      spectrum[j][1] = (n % 2 == 0 && j == n / 2) ? 0.0 : v.imag();
    }
    fftw_execute(backward);
    for (std::size_t i = 0; i < n; ++i) {
      y(static_cast<Eigen::Index>(i), c) = buffer[i] + first + slope * (static_cast<double>(i) - lag);
    }
  }
  fftw_destroy_plan(forward);
  fftw_destroy_plan(backward);
  return y;
}

/// Days at 1 Hz: a random-walk field (0.05 nT steps, the steep geomagnetic spectrum) plus 10 pT
/// white noise in the reference; T = filter(R_clean n) + 30 pT.
struct Pair {
  mic::VectorRecord reference, test;
  Eigen::Matrix3d n;
};
Pair simulate(unsigned seed, double days, double corner_hz, double delay) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> step(0.0, 0.05), ref_noise(0.0, 0.01), test_noise(0.0, 0.03);
  Pair p;
  p.n << 1.002, 0.004, -0.003, -0.005, 0.997, 0.006, 0.002, -0.004, 1.004;
  const auto samples = static_cast<Eigen::Index>(days * 86400.0);
  mic::Readings clean(samples, 3);
  Eigen::RowVector3d level(20000.0, 1000.0, 45000.0);
  for (Eigen::Index i = 0; i < samples; ++i) {
    for (int c = 0; c < 3; ++c) level(c) += step(rng);
    clean.row(i) = level;
  }
  const mic::Readings test = low_pass(clean * p.n, corner_hz, delay);
  for (mic::VectorRecord* r : {&p.reference, &p.test}) {
    r->values_nT.resize(samples, 3);
    r->time_s.resize(static_cast<std::size_t>(samples));
    for (Eigen::Index i = 0; i < samples; ++i) r->time_s[static_cast<std::size_t>(i)] = 1747180800.0 + static_cast<double>(i);
  }
  for (Eigen::Index i = 0; i < samples; ++i) {
    for (int c = 0; c < 3; ++c) {
      p.reference.values_nT(i, c) = clean(i, c) + ref_noise(rng);
      p.test.values_nT(i, c) = test(i, c) + test_noise(rng);
    }
  }
  p.reference.source = "reference";
  p.test.source = "test";
  return p;
}

struct Errors {
  double scale_pct = 0.0;  ///< largest |scale ratio error| of the three, %
  double angle_deg = 0.0;  ///< largest |non-orthogonality or misalignment error|, deg
};
Errors errors(const mic::CalibrationWindow& w, const Eigen::Matrix3d& n_true) {
  const auto truth = mic::decompose(n_true);
  const auto& e = w.estimate.parameters;
  Errors out;
  out.scale_pct = 100.0 * (e.scale_ratio - truth.scale_ratio).cwiseAbs().maxCoeff();
  out.angle_deg = std::max((e.nonorthogonality_deg - truth.nonorthogonality_deg).cwiseAbs().maxCoeff(),
                           (e.misalignment_deg - truth.misalignment_deg).cwiseAbs().maxCoeff());
  return out;
}

}  // namespace

TEST(ResponseModel, RemovingTheModelledFilterRestoresTheUnfilteredRecord) {
  const Pair p = simulate(5, 0.5, 0.0, 0);
  const mic::Readings filtered = low_pass(p.reference.values_nT, 0.03, 0);
  mic::ResponseModel model;
  model.applied = true;
  model.fit_max_hz = 0.5;  // Nyquist at 1 Hz
  model.inverse_corner_s = Eigen::Vector3d::Constant(1.0 / 0.03);
  const mic::Readings restored = mic::remove_modelled_filter(filtered, 1.0, model);
  // Up to fit_max_hz (here Nyquist) the inverse is exact: what is left is rounding.
  const mic::Readings diff = restored - p.reference.values_nT;
  const mic::Readings before = filtered - p.reference.values_nT;
  const double rms_after = std::sqrt(diff.squaredNorm() / static_cast<double>(diff.size()));
  const double rms_before = std::sqrt(before.squaredNorm() / static_cast<double>(before.size()));
  // What is left is the ends: the line taken out before the inverse runs through the filtered
  // end samples, not the original ones.
  EXPECT_GT(rms_before, 0.05);  // nT: the filter's lag on a random walk
  EXPECT_LT(rms_after, 0.01 * rms_before) << rms_after << " vs " << rms_before;
}

TEST(ResponseModel, FitsTheCornerAndDelayOfAFilteredPairAndNotOfAFlatOrLaggedOne) {
  mic::CalibrationSettings settings;
  settings.windows.intervals = 0;
  const Pair filtered = simulate(11, 2.0, 0.03, 2);
  settings.window.response_model = true;
  const auto with_filter = mic::calibrate_records(filtered.reference, filtered.test, settings);
  const mic::ResponseModel& m = with_filter.windows.back().response_model;
  ASSERT_TRUE(m.fitted) << m.text;
  ASSERT_TRUE(m.applied) << m.text;
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(m.corner_hz(k), 0.03, 0.003) << m.text;
    EXPECT_LE(std::abs(m.inverse_corner_s(k) - 1.0 / 0.03), std::max(m.inverse_corner_ci95_s(k), 0.5)) << m.text;
  }
  EXPECT_NEAR(m.delay_s, 2.0, 0.3) << m.text;
  const Pair flat = simulate(12, 2.0, 0.0, 0);
  const auto without = mic::calibrate_records(flat.reference, flat.test, settings);
  EXPECT_TRUE(without.windows.back().response_model.fitted);
  EXPECT_FALSE(without.windows.back().response_model.applied) << without.windows.back().response_model.text;
  // A pure 3 s lag (a time-stamping delay, as the WIC FGE's) is a delay, not a filter: its phase
  // alone would fit a corner, its flat gains do not.
  const Pair lagged = simulate(13, 2.0, 0.0, 3.0);
  const auto lag = mic::calibrate_records(lagged.reference, lagged.test, settings);
  const mic::ResponseModel& l = lag.windows.back().response_model;
  EXPECT_TRUE(l.fitted) << l.text;
  EXPECT_FALSE(l.applied) << l.text;
  EXPECT_NEAR(l.delay_s, 3.0, 0.2) << l.text;
}

// The held-out case: Eq. 2 over the default band (0.0002-0.01 Hz) takes the filter's
// roll-off for a loss of gain; estimated through the modelled response, n is unbiased.
TEST(ResponseModel, FilterMismatchDoesNotBiasNThroughTheModel) {
  mic::CalibrationSettings settings;
  double worst_without_z = 0.0, worst_with_z = 0.0;
  Eigen::Vector3d bias_with = Eigen::Vector3d::Zero(), bias_flat = Eigen::Vector3d::Zero();
  const unsigned first = 21, seeds = 4;
  for (unsigned seed = first; seed < first + seeds; ++seed) {
    const Pair p = simulate(seed, 2.0, 0.03, 2.0);
    const Pair flat = simulate(seed, 2.0, 0.0, 0.0);  // the same field and noise, no filter: the floor
    settings.window.response_model = false;
    const auto without = mic::calibrate_records(p.reference, p.test, settings).windows.back();
    settings.window.response_model = true;
    const auto with = mic::calibrate_records(p.reference, p.test, settings).windows.back();
    const auto floor = mic::calibrate_records(flat.reference, flat.test, settings).windows.back();
    const Eigen::Vector3d truth = mic::decompose(p.n).scale_ratio;
    // Without the model, the bias in units of n's own standard errors: before the band halves'
    // spread (halves_split.hpp), which carries part of it.
    const mic::CalibrationParameters own_without = mic::decompose(
        without.estimate.n, without.estimate.n_covariance - without.estimate.band_split.spread_covariance,
        without.estimate.covariance_dof);
    const Eigen::Vector3d z_without = (own_without.scale_ratio - truth).cwiseQuotient(
        own_without.scale_ratio_ci95 / own_without.interval_quantile);
    const Eigen::Vector3d z_with = (with.estimate.parameters.scale_ratio - truth).cwiseQuotient(
        with.estimate.parameters.scale_ratio_ci95 / with.estimate.parameters.interval_quantile);
    const Errors a = errors(without, p.n), b = errors(with, p.n), c = errors(floor, p.n);
    std::printf("seed %u: scale/angle error without the model %.3f %% %.3f deg, with it %.3f %% %.3f deg, "
                "unfiltered pair %.3f %% %.3f deg; z with %+.2f %+.2f %+.2f (%s)\n",
                seed, a.scale_pct, a.angle_deg, b.scale_pct, b.angle_deg, c.scale_pct, c.angle_deg, z_with(0),
                z_with(1), z_with(2), with.response_model.text.c_str());
    worst_without_z = std::max(worst_without_z, z_without.cwiseAbs().maxCoeff());
    worst_with_z = std::max(worst_with_z, z_with.cwiseAbs().maxCoeff());
    bias_with += (with.estimate.parameters.scale_ratio - truth) / seeds;
    bias_flat += (floor.estimate.parameters.scale_ratio - truth) / seeds;
  }
  std::printf("mean scale error, %%: with the model %+.4f %+.4f %+.4f; unfiltered pair %+.4f %+.4f %+.4f\n",
              100 * bias_with(0), 100 * bias_with(1), 100 * bias_with(2), 100 * bias_flat(0), 100 * bias_flat(1),
              100 * bias_flat(2));
  EXPECT_GT(worst_without_z, 5.0) << "the filter must bias the estimate without the model";
  EXPECT_LT(worst_with_z, 3.5) << "through the model, every scale ratio within 3.5 standard errors";
  EXPECT_LT(100 * bias_with.cwiseAbs().maxCoeff(), 0.05) << "mean scale error over the seeds, %";
}

// Gains flat within 0.5 % but a 1-pole's phase (0.08 Hz) on top of a 1 s lag: what the phase
// says could be a filter or stamping, the gains show no roll-off (a 1-pole at 0.08 Hz would be
// 0.67 at 0.09 Hz), so no corner counts (WIC's fourth quarter took its lag for X and Y corners
// before this rule).
TEST(ResponseModel, ACornerSeenOnlyInThePhaseDoesNotCount) {
  std::vector<mic::ResponseBand> bands;
  for (int i = 0; i < 20; ++i) {
    mic::ResponseBand b;
    b.frequency_hz = 0.001 * std::pow(100.0, i / 19.0);
    b.low_hz = b.frequency_hz * 0.9;
    b.high_hz = b.frequency_hz * 1.1;
    b.harmonics = 50;
    const double phase = -360.0 * b.frequency_hz * 1.0 - std::atan(b.frequency_hz / 0.08) * 180.0 / kPi;
    b.gain.setConstant(1.0);
    b.gain_ci95.setConstant(0.01);
    b.phase_deg.setConstant(phase);
    b.phase_ci95_deg.setConstant(0.6);
    bands.push_back(b);
  }
  const mic::ResponseModel m = mic::fit_response_model(bands);
  EXPECT_FALSE(m.applied) << m.text;
  // The same phase with the gains of that 1-pole: the corner counts.
  for (auto& b : bands) b.gain.setConstant(1.0 / std::hypot(1.0, b.frequency_hz / 0.08));
  const mic::ResponseModel filtered = mic::fit_response_model(bands);
  ASSERT_TRUE(filtered.applied) << filtered.text;
  EXPECT_NEAR(filtered.corner_hz(0), 0.08, 0.004) << filtered.text;
}

TEST(ResponseModel, ImpossibleSettingsAreRefused) {
  mic::ResponseModelSettings s;
  s.fit_max_hz = 0.0;
  EXPECT_THROW(s.validate(), mic::InputError);
  s = {};
  s.min_fit_max_hz = 1.0;
  EXPECT_THROW(s.validate(), mic::InputError);
  s = {};
  s.max_chi2_per_dof = 0.5;
  EXPECT_THROW(s.validate(), mic::InputError);
  s = {};
  s.max_corner_above_fit = 0.9;
  EXPECT_THROW(s.validate(), mic::InputError);
}
