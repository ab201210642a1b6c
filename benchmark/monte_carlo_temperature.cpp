// Monte Carlo of the temperature terms: a field hut with known coefficients
// (simulation/hut_temperature.hpp: daily cycle 3 degC, heater triangle 0.3 degC every ~30 min,
// offset 0.2/-0.15/0.3 nT/degC, scale 15/-10/25 ppm/degC), estimated by the package's default
// pipeline with the thermometer channel and without it (--temperature-channel none), on the
// SAME records. A program, not a test; figures in docs/temperature.md.
//
//   monte_carlo_temperature [seeds=100] [days=2] [first_seed=5000]   (MC_METHOD=plain: Eq. 2;
//                                                                     MC_NOISELESS_REFERENCE=1: no errors in variables)
//
// Prints per seed, then: coverage of the 95 % intervals of the apparent coefficient
// a = c + s F, of the offset c and of the scale s (9 values per seed); the median |error| and
// median 95 % half-width of each; for n: the mean error / se (bias), coverage of the six
// decomposed parameters (3 scale ratios, 3 non-orthogonalities) and the median half-width of
// the scale ratios, with and without the temperature terms.
#include "magnetometer_insitu_calibration/estimation/calibration_matrix.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/simulation/hut_temperature.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

struct Tally {
  std::size_t inside = 0, total = 0;
  std::vector<double> error, half_width;
  void add(double estimate, double truth, double ci95) {
    ++total;
    inside += std::abs(estimate - truth) <= ci95;
    error.push_back(std::abs(estimate - truth));
    half_width.push_back(ci95);
  }
  void print(const char* what, const char* unit) const {
    std::printf("%-34s coverage %5.1f %% (%zu/%zu)  median |error| %.4g %s  median ci95 %.4g %s\n", what,
                100.0 * static_cast<double>(inside) / static_cast<double>(std::max<std::size_t>(1, total)), inside, total,
                median(error), unit, median(half_width), unit);
  }
};

}  // namespace

int main(int argc, char** argv) {
  const int seeds = argc > 1 ? std::atoi(argv[1]) : 100;
  const double days = argc > 2 ? std::atof(argv[2]) : 2.0;
  const std::uint64_t first = argc > 3 ? std::strtoull(argv[3], nullptr, 10) : 5000;
  Tally apparent, offset, scale;
  Tally ratio_with, ratio_without, angle_with, angle_without;
  std::vector<double> z_with, z_without;  // (n - n_true) / se, all nine entries
  std::size_t fitted = 0;
  for (int k = 0; k < seeds; ++k) {
    const std::uint64_t seed = first + static_cast<std::uint64_t>(k);
    mic::SimulationSettings sim;
    sim.seed = seed;
    sim.duration_s = days * 86400.0;
    sim.keep_clean_field = false;
    if (std::getenv("MC_NOISELESS_REFERENCE") != nullptr) sim.reference_white_nT = sim.reference_pink_nT_per_sqrt_hz = 0.0;
    mic::SimulatedPair pair = mic::simulate_pair(sim);
    mic::HutTemperatureSettings hut;
    hut.seed = seed;
    mic::add_hut_temperature(pair, hut);
    const mic::CalibrationParameters truth = mic::decompose(pair.n_true);

    mic::CalibrationSettings settings;  // the package's defaults: robust, whole record
    if (const char* method = std::getenv("MC_METHOD")) settings.window.estimator.method = mic::parse_estimator_method(method);
    const mic::PairCalibration with = mic::calibrate_records(pair.reference, pair.test, settings);
    settings.preprocess.temperature_channel = "none";
    const mic::PairCalibration without = mic::calibrate_records(pair.reference, pair.test, settings);
    const mic::CalibrationWindow& w = with.windows.back();
    const mic::CalibrationWindow& wo = without.windows.back();
    if (!w.temperature.fitted) {
      std::printf("seed %llu: not fitted: %s\n", static_cast<unsigned long long>(seed), w.temperature.text.c_str());
      continue;
    }
    ++fitted;
    for (int l = 0; l < 3; ++l) {
      const double s_true = 1e-6 * hut.scale_ppm_per_C(l);
      const double a_true = hut.offset_nT_per_C(l) + s_true * pair.test.values_nT.col(l).mean();
      apparent.add(w.temperature.apparent_nT_per_C(l), a_true, w.temperature.apparent_ci95_nT_per_C(l));
      offset.add(w.temperature.offset_nT_per_C(l), hut.offset_nT_per_C(l), w.temperature.offset_ci95_nT_per_C(l));
      scale.add(w.temperature.scale_ppm_per_C(l), hut.scale_ppm_per_C(l), w.temperature.scale_ci95_ppm_per_C(l));
      ratio_with.add(w.estimate.parameters.scale_ratio(l), truth.scale_ratio(l), w.estimate.parameters.scale_ratio_ci95(l));
      ratio_without.add(wo.estimate.parameters.scale_ratio(l), truth.scale_ratio(l), wo.estimate.parameters.scale_ratio_ci95(l));
      angle_with.add(w.estimate.parameters.nonorthogonality_deg(l), truth.nonorthogonality_deg(l),
                     w.estimate.parameters.nonorthogonality_ci95_deg(l));
      angle_without.add(wo.estimate.parameters.nonorthogonality_deg(l), truth.nonorthogonality_deg(l),
                        wo.estimate.parameters.nonorthogonality_ci95_deg(l));
    }
    const Eigen::Matrix3d se_w = w.estimate.n_stderr(), se_wo = wo.estimate.n_stderr();
    for (int i = 0; i < 9; ++i) {
      z_with.push_back((w.estimate.n(i / 3, i % 3) - pair.n_true(i / 3, i % 3)) / se_w(i / 3, i % 3));
      z_without.push_back((wo.estimate.n(i / 3, i % 3) - pair.n_true(i / 3, i % 3)) / se_wo(i / 3, i % 3));
    }
    std::printf("seed %llu: apparent z %.4f +- %.4f nT/degC, scale z %.0f +- %.0f ppm/degC, Z ratio err with %.5f %% "
                "(ci %.5f), without %.5f %% (ci %.5f)\n",
                static_cast<unsigned long long>(seed), w.temperature.apparent_nT_per_C(2), w.temperature.apparent_ci95_nT_per_C(2),
                w.temperature.scale_ppm_per_C(2), w.temperature.scale_ci95_ppm_per_C(2),
                100.0 * (w.estimate.parameters.scale_ratio(2) - truth.scale_ratio(2)),
                100.0 * w.estimate.parameters.scale_ratio_ci95(2),
                100.0 * (wo.estimate.parameters.scale_ratio(2) - truth.scale_ratio(2)),
                100.0 * wo.estimate.parameters.scale_ratio_ci95(2));
    std::fflush(stdout);
  }
  auto mean = [](const std::vector<double>& v) {
    double s = 0.0;
    for (double x : v) s += x;
    return v.empty() ? std::nan("") : s / static_cast<double>(v.size());
  };
  auto rms = [](const std::vector<double>& v) {
    double s = 0.0;
    for (double x : v) s += x * x;
    return v.empty() ? std::nan("") : std::sqrt(s / static_cast<double>(v.size()));
  };
  std::printf("\n%zu of %d seeds fitted (%g days each, seeds %llu..)\n", fitted, seeds, days,
              static_cast<unsigned long long>(first));
  apparent.print("apparent coefficient a nT/degC", "nT/degC");
  offset.print("offset coefficient c nT/degC", "nT/degC");
  scale.print("scale coefficient s ppm/degC", "ppm/degC");
  ratio_with.print("scale ratios, with temperature", "");
  ratio_without.print("scale ratios, without", "");
  angle_with.print("non-orthogonality, with temperature", "deg");
  angle_without.print("non-orthogonality, without", "deg");
  std::printf("n entries (n - n_true)/se: with temperature mean %+.3f rms %.3f; without mean %+.3f rms %.3f\n",
              mean(z_with), rms(z_with), mean(z_without), rms(z_without));
  return 0;
}
