// Monte Carlo of calibration_node's three-cornered hat (issue 13: "three instruments of different
// noise, one reference and two tests, on one calibration node"), through the node's own window
// path without a master: the two channels' windows grouped by CoincidentWindows, each estimated by
// estimate_window_with_hat (live_three_cornered_hat.hpp), as the worker does.
//
//   monte_carlo_node_hat [seeds=200] [days=1] [first_seed=9000]
//   MC_REF_WHITE, MC_A_WHITE, MC_B_WHITE: the three white noise levels (nT; 0.1, 0.01, 0.05)
//   MC_SPIKES: 50 nT one-sample spikes per day in the reference and test a (simulator.hpp; 0),
//   MC_GAPS: gaps of 600 s in them (0); the live windows hold them as recorded (NaN in gaps);
//   MC_DESPIKE: the windows despiked (~despike true; the node's default is false)
//
// Per seed: one window of `days` at 1 Hz; by default reference white 0.1 nT (10x test a's
// 0.01 nT), test b white 0.05 nT with its own misalignment; default node settings (robust, eiv given, band
// 0.0002-0.01 Hz, response model on). Printed:
//  - each instrument's identified noise level (ASD of the white + 1/f fit of its hat bins,
//    fit_hat_instrument) / the simulated one, over the band and at the top bin (0.15-0.25 Hz),
//    mean over seeds and windows, and how many of them are within 20 %;
//  - test a's scale-ratio bias / scatter over the seeds, with the hat (the node's default with two
//    tests) and without (one test: no identified noise, no correction).
// Build: make -C build monte_carlo_node_hat (links the ROS layer's library, no master needed).
#include "bias_scatter.hpp"
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "magnetometer_insitu_calibration/ros/live_three_cornered_hat.hpp"
#include "magnetometer_insitu_calibration/simulation/co_located_instrument.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

/// ASD level (nT rms per sample for white noise, dt = 1 s) of a white + 1/f fit over [low, high].
Eigen::Vector3d level_nT(const Eigen::Vector3d& white, const Eigen::Vector3d& pink, double low, double high) {
  const double inverse_f = std::log(high / low) / (high - low);
  return (white.cwiseAbs2() + 0.5 * inverse_f * pink.cwiseAbs2()).cwiseSqrt();
}

}  // namespace

int main(int argc, char** argv) {
  const int seeds = argc > 1 ? std::atoi(argv[1]) : 200;
  const double days = argc > 2 ? std::atof(argv[2]) : 1.0;
  const std::uint64_t first_seed = argc > 3 ? std::strtoull(argv[3], nullptr, 10) : 9000;
  const auto env = [](const char* name, double fallback) {
    const char* v = std::getenv(name);
    return v != nullptr ? std::atof(v) : fallback;
  };
  const double truth_level[3] = {env("MC_REF_WHITE", 0.1), env("MC_A_WHITE", 0.01), env("MC_B_WHITE", 0.05)};  // nT
  const char* const names[3] = {"reference", "test a", "test b"};
  // [0]: the level over the band (what the EIV correction uses of the reference); [1]: at the
  // top bin, 0.15-0.25 Hz (the level a maker states, and where the hat's harmonics are).
  Eigen::Vector3d level_sum[2][3] = {{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()},
                                     {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()}};
  int within[2][3] = {{0, 0, 0}, {0, 0, 0}}, counted[3] = {0, 0, 0};
  double level_min[2][3] = {{1e9, 1e9, 1e9}, {1e9, 1e9, 1e9}}, level_max[2][3] = {{0, 0, 0}, {0, 0, 0}};
  std::vector<Eigen::Vector3d> err[2];
  int identified = 0;
  double seconds_hat = 0.0, seconds_alone = 0.0;  // wall time of the window estimates
  for (int k = 0; k < seeds; ++k) {
    mic::SimulationSettings s;
    s.seed = first_seed + static_cast<std::uint64_t>(k);
    s.duration_s = days * 86400.0;
    s.reference_white_nT = truth_level[0];
    s.test_white_nT = truth_level[1];
    s.reference_pink_nT_per_sqrt_hz = s.test_pink_nT_per_sqrt_hz = 0.0;
    s.keep_clean_field = true;
    s.spikes_per_day = env("MC_SPIKES", 0.0);
    s.gap_count = static_cast<int>(env("MC_GAPS", 0.0));
    s.gap_length_s = 600.0;
    const mic::SimulatedPair pair = mic::simulate_pair(s);
    // The node's two channels: the reference paired with each test, on the 1 Hz grid.
    mic::WindowData a;
    a.start_s = pair.reference.time_s.front();
    a.period_s = s.sample_period_s;
    a.expected_samples = pair.reference.time_s.size();
    a.paired.time_s = pair.reference.time_s;
    a.paired.reference_nT = pair.reference.values_nT;
    a.paired.test_nT = pair.test.values_nT;
    mic::WindowData b = a;
    b.paired.test_nT = mic::co_located_instrument(pair.field_nT, mic::co_located_instrument_matrix(), truth_level[2],
                                                  s.seed * 31 + 7);
    const mic::WindowData a_alone = a;

    mic::CoincidentWindows groups(2);
    groups.add(0, std::move(a));
    std::vector<mic::CoincidentWindows::Released> released = groups.add(1, std::move(b));
    if (released.size() != 2 || !released[0].mate) {
      std::fprintf(stderr, "seed %llu: windows not grouped\n", static_cast<unsigned long long>(s.seed));
      return 1;
    }
    const mic::EstimatorSettings defaults;
    mic::WindowEstimator estimator(defaults);
    mic::WindowGapRule rule;
    if (std::getenv("MC_DESPIKE") != nullptr) rule.despike = true;  // MC_DESPIKE: ~despike true
    mic::IdentifiedNoise noise;
    const auto t0 = std::chrono::steady_clock::now();
    const mic::WindowResult with_hat =
        mic::estimate_window_with_hat(std::move(released[0].window), released[0].mate.get(), "test 'b'", estimator, rule, noise);
    const auto t1 = std::chrono::steady_clock::now();
    const mic::WindowResult without = mic::estimate_window(a_alone, estimator, rule);
    const auto t2 = std::chrono::steady_clock::now();
    seconds_hat += std::chrono::duration<double>(t1 - t0).count();
    seconds_alone += std::chrono::duration<double>(t2 - t1).count();
    identified += noise.identified ? 1 : 0;
    const Eigen::Vector3d truth = mic::decompose(pair.n_true).scale_ratio;
    err[0].push_back(without.estimate.parameters.scale_ratio - truth);
    err[1].push_back(with_hat.estimate.parameters.scale_ratio - truth);
    // Each instrument's level from the hat's bins (the reference's is the fit the node used).
    for (int m = 0; m < 3 && !noise.hat.psd_nT2_per_hz[0].empty(); ++m) {
      Eigen::Vector3d white, pink;
      mic::fit_hat_instrument(noise.hat, static_cast<std::size_t>(m), s.sample_period_s, white, pink);
      const mic::EstimatorSettings& band = defaults;
      const Eigen::Vector3d ratio[2] = {
          level_nT(white, pink, band.band_low_hz, band.band_high_hz) / truth_level[m],
          level_nT(white, pink, noise.hat.bin_low_hz.back(), noise.hat.bin_high_hz.back()) / truth_level[m]};
      for (int c = 0; c < 3; ++c) ++counted[m];
      for (int where = 0; where < 2; ++where) {
        level_sum[where][m] += ratio[where];
        for (int c = 0; c < 3; ++c) {
          within[where][m] += std::abs(ratio[where](c) - 1.0) <= 0.2 ? 1 : 0;
          level_min[where][m] = std::min(level_min[where][m], ratio[where](c));
          level_max[where][m] = std::max(level_max[where][m], ratio[where](c));
        }
      }
    }
    std::printf("seed %llu: %s\n", static_cast<unsigned long long>(s.seed), noise.text.c_str());
    std::fflush(stdout);
  }
  std::printf("# %d seeds of %g d from %llu; reference noise identified in %d windows\n", seeds, days,
              static_cast<unsigned long long>(first_seed), identified);
  for (int where = 0; where < 2; ++where) {
    std::printf("%s| instrument | simulated white (nT) | identified / simulated level x, y, z (mean) | within 20 %% | range |\n|---|---|---|---|---|\n",
                where == 0 ? "level over the band (0.0002-0.01 Hz):\n" : "level at the top bin (0.15-0.25 Hz):\n");
    for (int m = 0; m < 3; ++m) {
      const Eigen::Vector3d mean = level_sum[where][m] / static_cast<double>(std::max(1, counted[m] / 3));
      std::printf("| %s | %.2f | %.3f, %.3f, %.3f | %d of %d | %.3f-%.3f |\n", names[m], truth_level[m], mean(0), mean(1),
                  mean(2), within[where][m], counted[m], level_min[where][m], level_max[where][m]);
    }
  }
  std::printf("| test a's estimate | scale-ratio bias / scatter x, y, z |\n|---|---|\n");
  for (int m = 0; m < 2; ++m) {
    const Eigen::Vector3d z = monte_carlo::bias_over_scatter(err[m]);
    std::printf("| %s | %.2f, %.2f, %.2f |\n", m == 0 ? "one test on the node (no noise identified)" : "two tests: the hat (node default)",
                z(0), z(1), z(2));
  }
  std::printf("# bias / scatter; its own standard error about 1 / sqrt(%d) = %.2f\n", seeds, 1.0 / std::sqrt(seeds));
  std::printf("# window estimate (estimate_window, relative response, response model), mean wall time: %.1f ms with "
              "the hat, %.1f ms with one test\n",
              1e3 * seconds_hat / seeds, 1e3 * seconds_alone / seeds);
  return 0;
}
