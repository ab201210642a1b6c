// Monte Carlo of the scalar check (estimation/scalar_check.hpp, pipeline/scalar_window.hpp)
// against known truth: a simulated quiet station whose reference reads its field with a scale
// error (MC_REFERENCE_SCALE, 1.003: 0.3 % high along every axis), and an absolute scalar
// magnetometer (scalar_magnetometer.hpp; 0.01 nT white) every `period` s, its stamps 0.37 s off
// whole seconds. Knobs for finding what limits the check: MC_SCALAR_WHITE (nT rms per sample,
// 0.01), MC_SCALAR_OFFSET (s, 0.37), MC_REFERENCE_PINK (the reference's 1/f noise, nT/sqrt(Hz)
// at 1 Hz, 0.005), MC_REFERENCE_WHITE (nT rms per sample, 0.01), MC_TRUE_NOISE=1 (the
// reference's true noise given as its figure instead of the noise identified from the pair),
// MC_PLAIN=1 (plain Eq. 2 instead of the default estimator). Per seed the default
// pipeline's whole-record window with the scalar: is the reference's scale along the field
// inside its 95 % interval, and how far off.
//
//   monte_carlo_scalar [seeds=200] [days=1] [period_s=1] [first_seed=46000]
//
// A program, not a test; its figures are quoted in docs/accuracy.md.
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/simulation/scalar_magnetometer.hpp"

#include "percentile.hpp"

#include <Eigen/LU>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

double knob(const char* name, double value) {
  const char* text = std::getenv(name);
  return text != nullptr ? std::atof(text) : value;
}


}  // namespace

int main(int argc, char** argv) {
  const int seeds = argc > 1 ? std::atoi(argv[1]) : 200;
  const double days = argc > 2 ? std::atof(argv[2]) : 1.0;
  const double period = argc > 3 ? std::atof(argv[3]) : 1.0;
  const std::uint64_t first = argc > 4 ? std::strtoull(argv[4], nullptr, 10) : 46000;
  const double k = knob("MC_REFERENCE_SCALE", 1.003);
  std::printf("# quiet station, %d seeds from %llu, %.1f days; reference scale %.4f; scalar every %g s\n", seeds,
              static_cast<unsigned long long>(first), days, k, period);
  std::printf("# seed  scale  ci95  (scale - truth) / se  test_scale  test_ci95\n");
  int covered = 0, assessed = 0, flagged = 0, test_covered = 0;
  std::vector<double> errors;
  double z_sum = 0.0, z_squares = 0.0;  // z = (scale - truth) / se
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < seeds; ++i) {
    mic::SimulationSettings s;
    s.seed = first + static_cast<std::uint64_t>(i);
    s.duration_s = days * 86400.0;
    s.keep_clean_field = true;
    s.reference_pink_nT_per_sqrt_hz = knob("MC_REFERENCE_PINK", s.reference_pink_nT_per_sqrt_hz);
    s.reference_white_nT = knob("MC_REFERENCE_WHITE", s.reference_white_nT);
    mic::SimulatedPair pair = mic::simulate_pair(s);
    mic::ScalarMagnetometerSettings sm;
    sm.seed = s.seed + 500;
    sm.period_s = period;
    sm.white_nT = knob("MC_SCALAR_WHITE", sm.white_nT);
    sm.offset_s = knob("MC_SCALAR_OFFSET", sm.offset_s);
    const mic::ScalarRecord scalar = mic::simulate_scalar_magnetometer(pair, sm);
    // The reference reads k B; the test still reads B n: against this reference its matrix is n / k.
    pair.reference.values_nT *= k;
    mic::CalibrationSettings settings;
    if (knob("MC_TRUE_NOISE", 0.0) == 1.0) {
      settings.window.reference_noise_figure.white_nT = Eigen::Vector3d::Constant(k * s.reference_white_nT);
      settings.window.reference_noise_figure.pink_nT_per_sqrt_hz = Eigen::Vector3d::Constant(k * s.reference_pink_nT_per_sqrt_hz);
    }
    if (knob("MC_PLAIN", 0.0) == 1.0) settings.window.estimator.method = mic::EstimatorMethod::kPlain;
    const mic::PairCalibration c = mic::calibrate_records(pair.reference, pair.test, settings, {nullptr, nullptr, &scalar});
    const mic::ScalarCheck& check = c.windows.back().scalar;
    if (!check.assessed) {
      std::printf("seed %llu not assessed: %s\n", static_cast<unsigned long long>(s.seed), check.text.c_str());
      continue;
    }
    ++assessed;
    const double se = check.reference_scale_ci95 / 1.96;
    covered += std::abs(check.reference_scale - k) <= check.reference_scale_ci95;
    flagged += check.reference_off;
    // The test reads B n with n's columns of unit norm or nearly (the simulator's scale ratios
    // ~1.0004): its scale along the field is 1 / |n^-1 b| for the field direction b.
    const Eigen::Vector3d b = (pair.field_nT.colwise().mean()).transpose().normalized();
    const double test_truth = 1.0 / (pair.n_true.inverse() * b).norm();
    test_covered += std::abs(check.test_scale - test_truth) <= check.test_scale_ci95;
    errors.push_back(100.0 * std::abs(check.reference_scale - k));
    z_sum += (check.reference_scale - k) / se;
    z_squares += std::pow((check.reference_scale - k) / se, 2);
    std::printf("seed %llu %.5f %.5f %+.2f %.5f %.5f\n", static_cast<unsigned long long>(s.seed), check.reference_scale,
                check.reference_scale_ci95, (check.reference_scale - k) / se, check.test_scale, check.test_scale_ci95);
    std::fflush(stdout);
  }
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("\n| scalar every | seeds assessed | reference scale inside its 95 %% interval | flagged (departs from 1) | "
              "median / 95th pct |error| | test scale inside | z mean, rms |\n|---|---|---|---|---|---|---|\n");
  const double m = std::max(1, assessed);
  std::printf("| %g s | %d of %d | %.1f %% | %.1f %% | %.3f / %.3f %% | %.1f %% | %+.2f, %.2f |\n", period, assessed,
              seeds, 100.0 * covered / m, 100.0 * flagged / m, percentile(errors, 0.5), percentile(errors, 0.95),
              100.0 * test_covered / m, z_sum / m, std::sqrt(z_squares / m));
  std::printf("# %.0f s\n", elapsed);
  return 0;
}
