// Monte Carlo of the summary's "record that would decide" (pipeline/tolerance_verdicts.hpp)
// against what longer records actually give. Per seed, a simulated quiet station of `days`;
// the default per-window stage on its first `short_h` hours measures how its 95 % half-widths
// narrow with length (its halves and quarters) and predicts, for each of the nine parameters,
// the length at which the half-width falls to a target: the short window's half-width divided by
// `factor`. Windows from the same start, 1.5, 2, 3, 4, 6 and 8 times as long (up to the record's
// length), give the length at which the half-width actually reached the target (log-log
// interpolation between the two bracketing windows). Prints the ratio predicted / actual:
// its median, 10th and 90th percentiles and the share within +-30 %; and the same for the
// stationary record's length, short_h x factor^2 (exponent 1/2, assumed rather than measured),
// whose misses are the actual lengths' own scatter.
//
//   monte_carlo_record_length [seeds=100] [days=2] [short_h=6] [factor=2] [first_seed=52000]
//
// A program, not a test; its figures are quoted in docs/validation.md.
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include "percentile.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {


Eigen::Matrix<double, 9, 1> half_widths(const mic::CalibrationParameters& p) {
  Eigen::Matrix<double, 9, 1> c;
  c << p.scale_ratio_ci95, p.nonorthogonality_ci95_deg, p.misalignment_ci95_deg;
  return c;
}

/// The length (s) at which the half-width first reaches `target` along (length, half-width)
/// pairs in increasing length, interpolated in log-log; NaN when it never does.
double crossing(const std::vector<std::pair<double, double>>& curve, double target) {
  for (std::size_t i = 1; i < curve.size(); ++i) {
    const auto [l0, c0] = curve[i - 1];
    const auto [l1, c1] = curve[i];
    if (c1 > target) continue;
    if (c0 <= target) return l0;
    const double f = std::log(c0 / target) / std::log(c0 / c1);
    return std::exp(std::log(l0) + f * std::log(l1 / l0));
  }
  return NAN;
}

}  // namespace

int main(int argc, char** argv) {
  const int seeds = argc > 1 ? std::atoi(argv[1]) : 100;
  const double days = argc > 2 ? std::atof(argv[2]) : 2.0;
  const double short_h = argc > 3 ? std::atof(argv[3]) : 6.0;
  const double factor = argc > 4 ? std::atof(argv[4]) : 2.0;
  const std::uint64_t first = argc > 5 ? std::strtoull(argv[5], nullptr, 10) : 52000;
  std::printf("# quiet station, %d seeds from %llu, %.1f days; predicted from the first %.1f h the length at which "
              "each half-width falls to 1/%.2f of it\n",
              seeds, static_cast<unsigned long long>(first), days, short_h, factor);
  std::printf("# seed  exponent  exponent_se  predicted_h  then per parameter: actual_h (nan: not reached)\n");
  mic::CalibrationSettings settings;
  // Tolerances far below any half-width: every verdict undecided, so the narrowing is measured.
  settings.window.tolerances.scale.setConstant(1e-9);
  settings.window.tolerances.nonorthogonality_deg.setConstant(1e-9);
  settings.window.tolerances.misalignment_deg.setConstant(1e-9);
  mic::WindowCalibrator calibrator(settings.window);
  // The longer windows only need their half-widths: tolerances that every parameter is within.
  mic::WindowCalibrationSettings long_settings = settings.window;
  long_settings.tolerances = mic::Tolerances{};
  long_settings.tolerances.scale.setConstant(1e9);
  long_settings.tolerances.nonorthogonality_deg.setConstant(1e9);
  long_settings.tolerances.misalignment_deg.setConstant(1e9);
  mic::WindowCalibrator long_calibrator(long_settings);
  std::vector<double> ratios, stationary_ratios, exponents;
  int unreached = 0;
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < seeds; ++i) {
    mic::SimulationSettings s;
    s.seed = first + static_cast<std::uint64_t>(i);
    s.duration_s = days * 86400.0;
    const mic::SimulatedPair pair = mic::simulate_pair(s);
    const mic::PreparedPair prepared = mic::prepare_pair(pair.reference, pair.test, settings.preprocess);
    const double period = prepared.sample_period_s;
    const auto samples_of = [&](double hours) { return static_cast<std::size_t>(std::llround(hours * 3600.0 / period)); };
    const mic::CalibrationWindow short_window = calibrator.calibrate(mic::window_records(prepared, 0, samples_of(short_h), 0.0));
    if (short_window.estimate.quality != mic::Quality::kOk || !short_window.narrowing.measured()) {
      std::printf("seed %llu: short window not usable: %s\n", static_cast<unsigned long long>(s.seed),
                  short_window.narrowing.text.c_str());
      continue;
    }
    const double a = short_window.narrowing.exponent;
    exponents.push_back(a);
    const double predicted_h = short_h * std::pow(factor, 1.0 / a);
    const Eigen::Matrix<double, 9, 1> c0 = half_widths(short_window.estimate.parameters);
    std::vector<std::vector<std::pair<double, double>>> curves(9);
    for (int k = 0; k < 9; ++k) curves[k].emplace_back(short_h, c0(k));
    for (double m : {1.5, 2.0, 3.0, 4.0, 6.0, 8.0}) {
      const std::size_t count = samples_of(short_h * m);
      if (count > prepared.paired.size()) break;
      const mic::CalibrationWindow w = long_calibrator.calibrate(mic::window_records(prepared, 0, count, 0.0));
      if (w.estimate.quality != mic::Quality::kOk) continue;
      const Eigen::Matrix<double, 9, 1> c = half_widths(w.estimate.parameters);
      for (int k = 0; k < 9; ++k) curves[k].emplace_back(short_h * m, c(k));
    }
    std::printf("%llu %.3f %.3f %.1f", static_cast<unsigned long long>(s.seed), a, short_window.narrowing.exponent_se,
                predicted_h);
    for (int k = 0; k < 9; ++k) {
      const double actual_h = crossing(curves[k], c0(k) / factor);
      std::printf(" %.1f", actual_h);
      if (std::isfinite(actual_h)) {
        ratios.push_back(predicted_h / actual_h);
        stationary_ratios.push_back(short_h * factor * factor / actual_h);
      } else {
        ++unreached;
      }
    }
    std::printf("\n");
    std::fflush(stdout);
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const auto share_within = [](const std::vector<double>& r) {
    const auto n = std::count_if(r.begin(), r.end(), [](double x) { return std::abs(x - 1.0) <= 0.3; });
    return r.empty() ? NAN : 100.0 * static_cast<double>(n) / static_cast<double>(r.size());
  };
  std::printf("exponent: median %.3f, 10th-90th percentile %.3f-%.3f\n", percentile(exponents, 0.5),
              percentile(exponents, 0.1), percentile(exponents, 0.9));
  std::printf("predicted / actual length: median %.3f, 10th-90th percentile %.3f-%.3f; within +-30 %%: %.1f %% of %zu "
              "(%d parameters did not reach the target within the record)\n",
              percentile(ratios, 0.5), percentile(ratios, 0.1), percentile(ratios, 0.9), share_within(ratios),
              ratios.size(), unreached);
  std::printf("stationary length (exponent 1/2, %.1f h) / actual: median %.3f, 10th-90th percentile %.3f-%.3f; "
              "within +-30 %%: %.1f %%\n",
              short_h * factor * factor, percentile(stationary_ratios, 0.5), percentile(stationary_ratios, 0.1),
              percentile(stationary_ratios, 0.9), share_within(stationary_ratios));
  std::printf("# %.0f s\n", seconds);
  return 0;
}
