// Monte Carlo of calibration_node's three-cornered hat (three instruments of different noise, one
// reference and two tests, on one calibration node), through the node's own window path without
// a master: the two channels' windows grouped by CoincidentWindows (pipeline/live_windows.hpp),
// each released with the other channel's record as its third instrument, and calibrated by the
// per-window stage (WindowCalibrator, pipeline/window_calibration.hpp), as the node's worker does.
//
//   monte_carlo_node_hat [seeds=200] [days=1] [first_seed=9000]
//   MC_REF_WHITE, MC_A_WHITE, MC_B_WHITE: the three white noise levels (nT; 0.1, 0.01, 0.05)
//   MC_SPIKES: 50 nT one-sample spikes per day in the reference and test a (simulator.hpp; 0),
//   MC_GAPS: gaps of 600 s in them (0); the live windows hold them as recorded (NaN in gaps);
//   MC_DESPIKE: each stream despiked before it is windowed, as the node's StreamingDespiker does
//   (~despike; it gives the batch despike's values); off unless set
//
// Per seed: one window of `days` at 1 Hz; by default reference white 0.1 nT (10x test a's
// 0.01 nT), test b white 0.05 nT with its own misalignment. Test a's window with the hat: the
// node's default window settings (robust, EIV correction on, band 0.0002-0.01 Hz, response model
// on); without: the same settings with the reference's noise from the pair above the band off,
// so that it has no noise model and no correction. Printed:
//  - each instrument's identified noise level (ASD of the white + 1/f fit of its hat bins,
//    fit_hat_instrument) / the simulated one, over the band and at the top bin (0.15-0.25 Hz),
//    mean over seeds and windows, and how many of them are within 20 %;
//  - test a's scale-ratio bias / scatter over the seeds, with the hat (the node's default with two
//    tests) and without (one test: no identified noise, no correction).
// Build: make -C build monte_carlo_node_hat (the core library only; no master needed).
#include "bias_scatter.hpp"
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "magnetometer_insitu_calibration/pipeline/live_windows.hpp"
#include "magnetometer_insitu_calibration/pipeline/reference_noise.hpp"
#include "magnetometer_insitu_calibration/pipeline/window_calibration.hpp"
#include "magnetometer_insitu_calibration/preprocessing/despike.hpp"
#include "magnetometer_insitu_calibration/simulation/co_located_instrument.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <utility>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

/// ASD level (nT rms per sample for white noise, dt = 1 s) of a white + 1/f fit over [low, high].
Eigen::Vector3d level_nT(const Eigen::Vector3d& white, const Eigen::Vector3d& pink, double low, double high) {
  const double inverse_f = std::log(high / low) / (high - low);
  return (white.cwiseAbs2() + 0.5 * inverse_f * pink.cwiseAbs2()).cwiseSqrt();
}

/// Each instrument's identified / simulated level: [0] over the band (what the EIV correction
/// uses of the reference), [1] at the top bin, 0.15-0.25 Hz (the level a maker states, and where
/// the hat's harmonics are).
struct LevelTally {
  Eigen::Vector3d sum[2][3] = {{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()},
                               {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()}};
  int within[2][3] = {{0, 0, 0}, {0, 0, 0}}, counted[3] = {0, 0, 0};
  double min[2][3] = {{1e9, 1e9, 1e9}, {1e9, 1e9, 1e9}}, max[2][3] = {{0, 0, 0}, {0, 0, 0}};

  /// The levels of the three instruments from the hat's bins (the reference's is the fit the
  /// window used).
  void add(const mic::ThreeCorneredHatResult& hat, double dt, const double (&truth)[3], const mic::EstimatorSettings& band) {
    for (int m = 0; m < 3 && !hat.psd_nT2_per_hz[0].empty(); ++m) {
      Eigen::Vector3d white, pink;
      mic::fit_hat_instrument(hat, static_cast<std::size_t>(m), dt, white, pink);
      const Eigen::Vector3d ratio[2] = {
          level_nT(white, pink, band.band_low_hz, band.band_high_hz) / truth[m],
          level_nT(white, pink, hat.bin_low_hz.back(), hat.bin_high_hz.back()) / truth[m]};
      for (int c = 0; c < 3; ++c) ++counted[m];
      for (int where = 0; where < 2; ++where) {
        sum[where][m] += ratio[where];
        for (int c = 0; c < 3; ++c) {
          within[where][m] += std::abs(ratio[where](c) - 1.0) <= 0.2 ? 1 : 0;
          min[where][m] = std::min(min[where][m], ratio[where](c));
          max[where][m] = std::max(max[where][m], ratio[where](c));
        }
      }
    }
  }

  void print(const double (&truth)[3]) const {
    const char* const names[3] = {"reference", "test a", "test b"};
    for (int where = 0; where < 2; ++where) {
      std::printf("%s| instrument | simulated white (nT) | identified / simulated level x, y, z (mean) | within 20 %% | range |\n|---|---|---|---|---|\n",
                  where == 0 ? "level over the band (0.0002-0.01 Hz):\n" : "level at the top bin (0.15-0.25 Hz):\n");
      for (int m = 0; m < 3; ++m) {
        const Eigen::Vector3d mean = sum[where][m] / static_cast<double>(std::max(1, counted[m] / 3));
        std::printf("| %s | %.2f | %.3f, %.3f, %.3f | %d of %d | %.3f-%.3f |\n", names[m], truth[m], mean(0), mean(1),
                    mean(2), within[where][m], counted[m], min[where][m], max[where][m]);
      }
    }
  }
};

double env(const char* name, double fallback) {
  const char* v = std::getenv(name);
  return v != nullptr ? std::atof(v) : fallback;
}

/// The window of a whole simulated record as the node's sliding buffer releases it: the
/// reference and one test on the 1 Hz grid, NaN where the simulator left gaps.
mic::WindowRecords whole_window(const mic::SimulatedPair& pair, const mic::Readings& test_nT, double period_s) {
  mic::WindowRecords w;
  w.start_s = pair.reference.time_s.front();
  w.period_s = period_s;
  w.expected_samples = pair.reference.time_s.size();
  w.paired.time_s = pair.reference.time_s;
  w.paired.reference_nT = pair.reference.values_nT;
  w.paired.test_nT = test_nT;
  return w;
}

}  // namespace

int main(int argc, char** argv) {
  const int seeds = argc > 1 ? std::atoi(argv[1]) : 200;
  const double days = argc > 2 ? std::atof(argv[2]) : 1.0;
  const std::uint64_t first_seed = argc > 3 ? std::strtoull(argv[3], nullptr, 10) : 9000;
  const double truth_level[3] = {env("MC_REF_WHITE", 0.1), env("MC_A_WHITE", 0.01), env("MC_B_WHITE", 0.05)};  // nT
  const bool despiking = std::getenv("MC_DESPIKE") != nullptr;
  const mic::WindowCalibrationSettings node_default;  // the node's window settings: the hat with two tests
  mic::WindowCalibrationSettings no_noise = node_default;  // one test, no noise identified
  no_noise.pair_noise = false;
  mic::WindowCalibrator with_hat_stage(node_default), alone_stage(no_noise);
  LevelTally levels;
  std::vector<Eigen::Vector3d> err[2];
  int identified = 0;
  double seconds_hat = 0.0, seconds_alone = 0.0;  // wall time of the window calibrations
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
    mic::SimulatedPair pair = mic::simulate_pair(s);
    mic::Readings test_b = mic::co_located_instrument(pair.field_nT, mic::co_located_instrument_matrix(),
                                                      truth_level[2], s.seed * 31 + 7);
    if (despiking) {  // each stream at its own rate, as the node's StreamingDespiker
      const mic::DespikeSettings despike_settings;
      mic::despike(pair.reference.values_nT, despike_settings);
      mic::despike(pair.test.values_nT, despike_settings);
      mic::despike(test_b, despike_settings);
    }
    // The node's two channels: the reference paired with each test, on the 1 Hz grid.
    mic::WindowRecords a = whole_window(pair, pair.test.values_nT, s.sample_period_s);
    mic::WindowRecords b = whole_window(pair, test_b, s.sample_period_s);
    const mic::WindowRecords a_alone = a;

    mic::CoincidentWindows groups(2);
    groups.add(0, std::move(a));
    std::vector<mic::CoincidentWindows::Released> released = groups.add(1, std::move(b));
    if (released.size() != 2 || released[0].channel != 0 || !released[0].window.third) {
      std::fprintf(stderr, "seed %llu: windows not grouped\n", static_cast<unsigned long long>(s.seed));
      return 1;
    }
    released[0].window.third_name = "test 'b'";  // as the node names a channel's mate
    const auto t0 = std::chrono::steady_clock::now();
    const mic::CalibrationWindow with_hat = with_hat_stage.calibrate(std::move(released[0].window));
    const auto t1 = std::chrono::steady_clock::now();
    const mic::CalibrationWindow without = alone_stage.calibrate(a_alone);
    const auto t2 = std::chrono::steady_clock::now();
    seconds_hat += std::chrono::duration<double>(t1 - t0).count();
    seconds_alone += std::chrono::duration<double>(t2 - t1).count();
    const mic::IdentifiedNoise& noise = with_hat.reference_noise;
    identified += with_hat.estimate.eiv_noise.source == mic::NoiseSource::kThreeCorneredHat ? 1 : 0;
    const Eigen::Vector3d truth = mic::decompose(pair.n_true).scale_ratio;
    err[0].push_back(without.estimate.parameters.scale_ratio - truth);
    err[1].push_back(with_hat.estimate.parameters.scale_ratio - truth);
    levels.add(noise.hat, s.sample_period_s, truth_level, node_default.estimator);
    std::printf("seed %llu: %s\n", static_cast<unsigned long long>(s.seed), noise.text.c_str());
    std::fflush(stdout);
  }
  std::printf("# %d seeds of %g d from %llu; reference noise identified in %d windows\n", seeds, days,
              static_cast<unsigned long long>(first_seed), identified);
  levels.print(truth_level);
  std::printf("| test a's estimate | scale-ratio bias / scatter x, y, z |\n|---|---|\n");
  for (int m = 0; m < 2; ++m) {
    const Eigen::Vector3d z = monte_carlo::bias_over_scatter(err[m]);
    std::printf("| %s | %.2f, %.2f, %.2f |\n", m == 0 ? "one test on the node (no noise identified)" : "two tests: the hat (node default)",
                z(0), z(1), z(2));
  }
  std::printf("# bias / scatter; its own standard error about 1 / sqrt(%d) = %.2f\n", seeds, 1.0 / std::sqrt(seeds));
  std::printf("# window calibration (WindowCalibrator: gaps, estimate, relative response, response model), mean wall "
              "time: %.1f ms with the hat, %.1f ms with one test\n",
              1e3 * seconds_hat / seeds, 1e3 * seconds_alone / seeds);
  return 0;
}
