// Monte Carlo accuracy of the plain Eq. 2 chain on quiet simulated stations (a program, not a
// test): for each seed, one day at 1 Hz (or --rate 10 for the 10 Hz chain with decimation)
// from the package's simulator with the paper's scale ratios, angles of 0.01-0.3 deg, white and
// 1/f noise and a drift; reports the error distribution and the 95 % interval coverage.
//   monte_carlo_accuracy [--seeds 500] [--rate 1] [--days 1] [--method plain|robust]
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

double percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * (v.size() - 1))];
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 500;
  double rate_hz = 1.0, days = 1.0;
  std::string method = "plain";
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--seeds")) seeds = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--rate")) rate_hz = std::atof(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--days")) days = std::atof(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--method")) method = argv[i + 1];
    else { std::fprintf(stderr, "unknown option %s\n", argv[i]); return 2; }
  }
  const char* names[9] = {"scale x", "scale y", "scale z", "nonorth xy", "nonorth xz", "nonorth yz",
                          "misalign x", "misalign y", "misalign z"};
  std::vector<double> errors[9];
  int covered[9] = {0}, matrix_covered = 0, ok = 0;
  for (int seed = 1; seed <= seeds; ++seed) {
    mic::SimulationSettings s;
    s.seed = static_cast<std::uint64_t>(seed);
    s.duration_s = days * 86400.0;
    s.sample_period_s = 1.0 / rate_hz;
    s.keep_clean_field = false;
    s.drift_nT_per_day = Eigen::Vector3d(2.0, -1.0, 3.0);
    const mic::SimulatedPair pair = mic::simulate_pair(s);
    const mic::CalibrationParameters truth = mic::decompose(pair.n_true);
    mic::CalibrationSettings settings;
    settings.window.estimator.method = mic::parse_estimator_method(method);
    const auto w = mic::calibrate_records(pair.reference, pair.test, settings).windows.at(0);
    const auto& e = w.estimate;
    ok += e.quality == mic::Quality::kOk;
    const auto& p = e.parameters;
    Eigen::Matrix<double, 9, 1> est, tru, ci;
    est << p.scale_ratio, p.nonorthogonality_deg, p.misalignment_deg;
    tru << truth.scale_ratio, truth.nonorthogonality_deg, truth.misalignment_deg;
    ci << p.scale_ratio_ci95, p.nonorthogonality_ci95_deg, p.misalignment_ci95_deg;
    for (int k = 0; k < 9; ++k) {
      errors[k].push_back(std::abs(est(k) - tru(k)));
      covered[k] += std::abs(est(k) - tru(k)) <= ci(k);
    }
    const Eigen::Matrix3d se = e.n_stderr();
    for (int k = 0; k < 9; ++k) {
      matrix_covered += std::abs(e.n(k / 3, k % 3) - pair.n_true(k / 3, k % 3)) <= 1.959964 * se(k / 3, k % 3);
    }
  }
  std::printf("%d seeds, %.1f day(s) at %.0f Hz, method %s, quality ok in %d\n", seeds, days, rate_hz,
              method.c_str(), ok);
  std::printf("| parameter | median abs error | 95th percentile abs error | 95 %% interval coverage |\n");
  std::printf("|---|---|---|---|\n");
  for (int k = 0; k < 9; ++k) {
    const bool scale = k < 3;
    const double f = scale ? 100.0 : 1.0;  // scale errors in %, angles in degrees
    std::printf("| %s | %.5f %s | %.5f %s | %.1f %% |\n", names[k], f * percentile(errors[k], 0.5),
                scale ? "%" : "deg", f * percentile(errors[k], 0.95), scale ? "%" : "deg",
                100.0 * covered[k] / seeds);
  }
  std::printf("matrix entries: 95 %% interval coverage %.1f %% of %d\n", 100.0 * matrix_covered / (9.0 * seeds),
              9 * seeds);
  return 0;
}
