// What windows waiting for a late remote cost (LiveStreamSettings::remote_max_wait_s): the live
// streams of calibration_node (LiveCalibrationStreams, no ROS) fed a 10 Hz pair and a remote
// observatory at 1 s whose samples come LAG hours of stamps behind the pair's, with 24-hour
// windows every hour. A program, not a test; its figures are quoted in docs/performance.md.
//
//   bench_remote_wait [hours=36] [lag_hours=6] [remote=1]
//
// Prints the most windows waiting at once, the samples the streams hold (the remote's epochs,
// the waiting windows' epochs), the process's peak resident memory (getrusage) and the CPU time
// of the feeding. remote=0: the same pair without a remote, for the difference. The pair is a
// smooth field with white noise (the estimator does not run: only the streams are measured).
#include "magnetometer_insitu_calibration/pipeline/live_streams.hpp"

#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

namespace mic = magnetometer_insitu_calibration;

namespace {

double peak_rss_mb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // kB on Linux
}

Eigen::Vector3d field_nT(double t_s, std::mt19937& noise) {
  std::normal_distribution<double> white(0.0, 0.01);
  const double w = 2.0 * M_PI / 3600.0;
  return {20000.0 + 5.0 * std::sin(w * t_s) + white(noise), 1500.0 + 3.0 * std::cos(0.7 * w * t_s) + white(noise),
          44000.0 + 2.0 * std::sin(1.3 * w * t_s) + white(noise)};
}

}  // namespace

int main(int argc, char** argv) {
  const double hours = argc > 1 ? std::atof(argv[1]) : 36.0;
  const double lag_h = argc > 2 ? std::atof(argv[2]) : 6.0;
  const bool with_remote = argc > 3 ? std::atoi(argv[3]) != 0 : true;
  mic::LiveStreamSettings live;
  live.input_period_s = 0.1;
  live.window_s = 86400.0;
  live.step_s = 3600.0;
  live.remote_input_period_s = 1.0;
  live.remote_max_wait_s = (lag_h + 1.0) * 3600.0;
  mic::LiveCalibrationStreams streams(live, {{"test", false}}, false);
  if (with_remote) streams.add_remote("/remote/magnetic_field");
  std::mt19937 noise(7);
  const double start_s = 1747180800.0;
  const auto n = static_cast<long long>(hours * 36000.0);
  const auto lag = static_cast<long long>(lag_h * 36000.0);
  std::size_t windows = 0, most_waiting = 0, most_held = 0, remote_held = 0;
  const double rss_before = peak_rss_mb();
  const auto t0 = std::chrono::steady_clock::now();
  for (long long i = 0; i < n; ++i) {
    const double t = start_s + 0.1 * static_cast<double>(i);
    windows += streams.push_reference(t, field_nT(t, noise)).size();
    windows += streams.push_test(0, t, field_nT(t, noise)).size();
    const long long j = i - lag;  // the remote's sample of LAG hours ago, one a second
    if (with_remote && j >= 0 && j % 10 == 0) {
      const double tr = start_s + 0.1 * static_cast<double>(j);
      windows += streams.push_remote(tr, field_nT(tr, noise)).size();
    }
    if (i % 36000 == 0) {
      most_waiting = std::max(most_waiting, streams.waiting_for_remote());
      remote_held = streams.remote() != nullptr ? std::max(remote_held, streams.remote()->buffered()) : 0;
      most_held = std::max(most_held, streams.waiting_epochs());
    }
  }
  const double cpu_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("# %g h of a 10 Hz pair, 24 h windows every hour, remote %s\n", hours,
              with_remote ? "at 1 s, lag given" : "none");
  std::printf("lag_h %g  windows_out %zu  most_waiting %zu  waiting_epochs %zu  remote_epochs %zu  "
              "peak_rss_MB %.1f (before %.1f)  wall_s %.2f\n",
              with_remote ? lag_h : 0.0, windows, most_waiting, most_held, remote_held, peak_rss_mb(), rss_before, cpu_s);
  return 0;
}
