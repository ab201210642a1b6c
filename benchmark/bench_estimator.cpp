// Benchmark (a program, not a test): the full FD-WLSE estimate (load, FFT of 7 columns, band
// sums, covariance, decomposition) against the FFTW transforms alone (load + the same batched
// plan) on the same simulated 1 Hz data, 2 and 10 days; and the default robust estimator. docs/performance.md quotes its output:
//   build/devel/lib/magnetometer_insitu_calibration/bench_estimator --benchmark_repetitions=5
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/estimation/robust_estimator.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <benchmark/benchmark.h>

#include <map>

namespace mic = magnetometer_insitu_calibration;

namespace {

const mic::SimulatedPair& data_for_days(int days) {
  static std::map<int, mic::SimulatedPair> cache;
  auto it = cache.find(days);
  if (it == cache.end()) {
    mic::SimulationSettings s;
    s.duration_s = days * 86400.0;
    s.keep_clean_field = false;
    it = cache.emplace(days, mic::simulate_pair(s)).first;
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

/// The default (robust) estimator of the offline pipeline on the same data, for scale.
void robust_estimate(benchmark::State& state) {
  const auto& pair = data_for_days(static_cast<int>(state.range(0)));
  mic::WindowEstimator estimator(mic::EstimatorSettings{});
  for (auto _ : state) {
    const mic::WindowEstimate e = estimator.estimate(pair.reference.values_nT, pair.test.values_nT, 1.0);
    benchmark::DoNotOptimize(e.n(0, 0));
  }
  state.counters["samples"] = static_cast<double>(pair.reference.size());
}

void transforms_only(benchmark::State& state) {
  const auto& pair = data_for_days(static_cast<int>(state.range(0)));
  mic::FdWlseEstimator estimator;
  for (auto _ : state) {
    benchmark::DoNotOptimize(estimator.transform_only(pair.reference.values_nT, pair.test.values_nT));
  }
  state.counters["samples"] = static_cast<double>(pair.reference.size());
}

}  // namespace

BENCHMARK(full_estimate)->Arg(2)->Arg(10)->Unit(benchmark::kMillisecond);
BENCHMARK(robust_estimate)->Arg(2)->Arg(10)->Unit(benchmark::kMillisecond);
BENCHMARK(transforms_only)->Arg(2)->Arg(10)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
