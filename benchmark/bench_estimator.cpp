// Benchmark (a program, not a test): on the same simulated 1 Hz data, 2 and 10 days,
//  - transforms_only: the FFTW transforms of Eq. 2's 7 columns (R, the trend column, T: each
//    loaded minus its mean, one batched FFTW plan), the floor the other figures are divided by
//    (the plain estimate itself transforms the six data columns and takes the trend column's DFT
//    in closed form);
//  - full_estimate: the plain FD-WLSE estimate (Eq. 2, covariance, decomposition);
//  - robust_estimate: the default window estimate (WindowEstimator(EstimatorSettings{}): screen,
//    sections, IRLS, delay, sandwich and jackknife intervals, trend; no reference noise model
//    among its inputs, so no EIV correction);
//  - window_outputs: the default estimate plus the relative response, the per-window stage's
//    (WindowCalibrator) outputs with the default settings less the response model and the
//    reference's noise from the pair (and the second estimate those may ask for);
//  - robust_disturbed: the default estimate on the same records with traffic, spikes and a step
//    added (the disturbances of monte_carlo_disturbed): the screen masks about 11 % of the
//    samples, so its second pass and the Eq. 2 estimates on the screened records are paid;
//  - robust_remote: the default estimate on the clean records with a remote observatory
//    (simulate_remote_observatory's defaults, 20 % of its variance its own) as its instruments:
//    the instrumental-variable fit, the remote's strength and the pair-only comparison; its
//    ratio to robust_estimate is what a remote costs per window.
// After the run it prints each one's CPU time divided by transforms_only's of the same length:
// ratios of the means, medians and minima over the repetitions when there are several (on a
// shared machine the medians and minima move less). docs/performance.md quotes its output:
//   build/devel/lib/magnetometer_insitu_calibration/bench_estimator --benchmark_repetitions=5
//     --benchmark_report_aggregates_only=true
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/estimation/relative_response.hpp"
#include "magnetometer_insitu_calibration/estimation/robust/robust_estimator.hpp"
#include "magnetometer_insitu_calibration/simulation/remote_observatory.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "magnetometer_insitu_calibration/simulation/station_disturbances.hpp"

#include <benchmark/benchmark.h>
#include <fftw3.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

mic::SimulationSettings settings_for_days(int days) {
  mic::SimulationSettings s;
  s.duration_s = days * 86400.0;
  s.keep_clean_field = false;
  return s;
}

const mic::SimulatedPair& data_for_days(int days) {
  static std::map<int, mic::SimulatedPair> cache;
  auto it = cache.find(days);
  if (it == cache.end()) it = cache.emplace(days, mic::simulate_pair(settings_for_days(days))).first;
  return it->second;
}

/// A remote observatory beside data_for_days(days): the same records with their clean field kept.
const mic::Readings& remote_for_days(int days) {
  static std::map<int, mic::Readings> cache;
  auto it = cache.find(days);
  if (it == cache.end()) {
    mic::SimulationSettings s = settings_for_days(days);
    s.keep_clean_field = true;
    const mic::SimulatedPair pair = mic::simulate_pair(s);
    mic::RemoteObservatorySettings r;
    r.seed = s.seed + 7000;
    it = cache.emplace(days, mic::simulate_remote_observatory(s, pair, r).values_nT).first;
  }
  return it->second;
}

const mic::SimulatedPair& disturbed_data_for_days(int days) {
  static std::map<int, mic::SimulatedPair> cache;
  auto it = cache.find(days);
  if (it == cache.end()) {
    mic::SimulatedPair pair = data_for_days(days);
    mic::StationDisturbanceSettings d;  // as monte_carlo_disturbed's defaults
    d.vehicles_per_day = 150;
    d.parking_probability = 0.03;
    d.small_spikes_per_day = 100;
    d.steps = 1;
    mic::add_station_disturbances(pair, d);
    it = cache.emplace(days, std::move(pair)).first;
  }
  return it->second;
}

void full_estimate(benchmark::State& state) {
  const auto& pair = data_for_days(static_cast<int>(state.range(0)));
  mic::FdWlseEstimator estimator;
  for (auto _ : state) {
    const mic::WindowEstimate e = estimator.estimate(pair.reference.values_nT, pair.test.values_nT, 1.0);
    benchmark::DoNotOptimize(e.n(0, 0));
  }
  state.counters["samples"] = static_cast<double>(pair.reference.size());
}

/// The default (robust) estimator of the offline pipeline on the same data.
void robust_estimate(benchmark::State& state) {
  const auto& pair = data_for_days(static_cast<int>(state.range(0)));
  mic::WindowEstimator estimator(mic::EstimatorSettings{});
  for (auto _ : state) {
    const mic::WindowEstimate e = estimator.estimate(pair.reference.values_nT, pair.test.values_nT, 1.0);
    benchmark::DoNotOptimize(e.n(0, 0));
  }
  state.counters["samples"] = static_cast<double>(pair.reference.size());
}

/// The default estimate and the relative response: every output a pipeline window has by default.
void window_outputs(benchmark::State& state) {
  const auto& pair = data_for_days(static_cast<int>(state.range(0)));
  mic::WindowEstimator estimator(mic::EstimatorSettings{});
  const mic::RelativeResponseSettings response;
  for (auto _ : state) {
    const mic::WindowEstimate e = estimator.estimate(pair.reference.values_nT, pair.test.values_nT, 1.0);
    const auto bands = mic::relative_response(pair.reference.values_nT, pair.test.values_nT, e.n, 1.0, response);
    benchmark::DoNotOptimize(e.n(0, 0));
    benchmark::DoNotOptimize(bands.data());
  }
  state.counters["samples"] = static_cast<double>(pair.reference.size());
}

void robust_disturbed(benchmark::State& state) {
  const auto& pair = disturbed_data_for_days(static_cast<int>(state.range(0)));
  mic::WindowEstimator estimator(mic::EstimatorSettings{});
  double screened = 0.0;
  for (auto _ : state) {
    const mic::WindowEstimate e = estimator.estimate(pair.reference.values_nT, pair.test.values_nT, 1.0);
    screened = e.screened_fraction;
    benchmark::DoNotOptimize(e.n(0, 0));
  }
  state.counters["samples"] = static_cast<double>(pair.reference.size());
  state.counters["screened"] = screened;
}

void robust_remote(benchmark::State& state) {
  const int days = static_cast<int>(state.range(0));
  const auto& pair = data_for_days(days);
  mic::WindowInputs inputs;
  inputs.remote_nT = &remote_for_days(days);
  inputs.remote_name = "simulated remote";
  mic::WindowEstimator estimator(mic::EstimatorSettings{});
  bool used = false;
  for (auto _ : state) {
    const mic::WindowEstimate e = estimator.estimate(pair.reference.values_nT, pair.test.values_nT, 1.0, inputs);
    used = e.remote.used;
    benchmark::DoNotOptimize(e.n(0, 0));
  }
  if (!used) state.SkipWithError("the remote was not used");
  state.counters["samples"] = static_cast<double>(pair.reference.size());
}

/// The 7 columns of Eq. 2 with the trend column, loaded minus their means and transformed by one
/// batched FFTW plan (FFTW_ESTIMATE, as the estimators plan).
void transforms_only(benchmark::State& state) {
  const auto& pair = data_for_days(static_cast<int>(state.range(0)));
  const int n = static_cast<int>(pair.reference.size()), columns = 7, bins = n / 2 + 1;
  double* in = fftw_alloc_real(static_cast<std::size_t>(n) * columns);
  fftw_complex* out = fftw_alloc_complex(static_cast<std::size_t>(bins) * columns);
  fftw_plan plan = fftw_plan_many_dft_r2c(1, &n, columns, in, nullptr, 1, n, out, nullptr, 1, bins, FFTW_ESTIMATE);
  for (auto _ : state) {
    for (int c = 0; c < columns; ++c) {
      double* column = in + static_cast<std::size_t>(c) * static_cast<std::size_t>(n);
      if (c == 3) {  // the trend column, days from the window's centre
        for (int i = 0; i < n; ++i) column[i] = (i - 0.5 * (n - 1)) / 86400.0;
        continue;
      }
      const auto series = (c < 3 ? pair.reference.values_nT : pair.test.values_nT).col(c < 3 ? c : c - 4);
      const double mean = series.mean();
      for (int i = 0; i < n; ++i) column[i] = series(i) - mean;
    }
    fftw_execute(plan);
    benchmark::DoNotOptimize(out[1][0]);
  }
  fftw_destroy_plan(plan);
  fftw_free(in);
  fftw_free(out);
  state.counters["samples"] = static_cast<double>(pair.reference.size());
}

/// The console output, and each benchmark's CPU time (ms) kept for the ratios: the "mean"
/// aggregate when there are repetitions, otherwise the mean of the runs.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& run : runs) {
      if (run.error_occurred) continue;
      const std::string key = run.run_name.function_name + "/" + run.run_name.args;
      const double ms = run.GetAdjustedCPUTime();  // in the benchmark's unit: ms here
      if (run.run_type == Run::RT_Aggregate) {
        aggregates_[run.aggregate_name][key] = ms;
      } else {
        auto& [sum, count] = runs_[key];
        sum += ms;
        ++count;
      }
    }
  }

  /// CPU ms of `key` by the aggregate `statistic` ("mean", "median", "min") over the repetitions;
  /// without repetitions the mean of the runs.
  double cpu_ms(const std::string& key, const std::string& statistic = "mean") const {
    if (auto a = aggregates_.find(statistic); a != aggregates_.end()) {
      if (auto it = a->second.find(key); it != a->second.end()) return it->second;
    }
    if (aggregates_.empty()) {
      if (auto it = runs_.find(key); it != runs_.end()) return it->second.first / it->second.second;
    }
    return -1.0;
  }

  bool has_repetitions() const { return !aggregates_.empty(); }

 private:
  std::map<std::string, std::map<std::string, double>> aggregates_;
  std::map<std::string, std::pair<double, int>> runs_;
};

}  // namespace

/// The fastest repetition: on a shared machine the least disturbed one.
double minimum(const std::vector<double>& v) { return v.empty() ? 0.0 : *std::min_element(v.begin(), v.end()); }

BENCHMARK(full_estimate)->Arg(2)->Arg(10)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", minimum);
BENCHMARK(robust_estimate)->Arg(2)->Arg(10)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", minimum);
BENCHMARK(window_outputs)->Arg(2)->Arg(10)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", minimum);
BENCHMARK(robust_disturbed)->Arg(2)->Arg(10)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", minimum);
BENCHMARK(robust_remote)->Arg(2)->Arg(10)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", minimum);
BENCHMARK(transforms_only)->Arg(2)->Arg(10)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", minimum);

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  for (const char* statistic : {"mean", "median", "min"}) {
    if (!reporter.has_repetitions() && std::string(statistic) != "mean") break;
    std::printf("\nCPU time / transforms_only (FFTW transforms of the 7 columns, same length), %s%s:\n", statistic,
                reporter.has_repetitions() ? " over the repetitions" : " of the runs");
    for (const char* days : {"2", "10"}) {
      const double floor_ms = reporter.cpu_ms(std::string("transforms_only/") + days, statistic);
      if (!(floor_ms > 0.0)) continue;
      std::printf("  %2s days: transforms %.2f ms", days, floor_ms);
      for (const char* name : {"full_estimate", "robust_estimate", "window_outputs", "robust_disturbed", "robust_remote"}) {
        const double ms = reporter.cpu_ms(std::string(name) + "/" + days, statistic);
        if (ms > 0.0) std::printf("; %s %.4g ms = %.2fx", name, ms, ms / floor_ms);
      }
      const double pair_ms = reporter.cpu_ms(std::string("robust_estimate/") + days, statistic);
      const double remote_ms = reporter.cpu_ms(std::string("robust_remote/") + days, statistic);
      if (pair_ms > 0.0 && remote_ms > 0.0) std::printf("; remote / pair-only default %.2fx", remote_ms / pair_ms);
      std::printf("\n");
    }
  }
  return 0;
}
