// The live side of calibration without ROS (pipeline/live_windows.hpp, live_streams.hpp,
// preprocessing/streaming_despike.hpp): the sliding window, the stream monitor, the thermometer
// buffer, the coincident windows of several tests, the streaming despiker against the batch one,
// and the live streams against the offline preparation of the same samples (a remote's and a
// scalar magnetometer's too).
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/pipeline/live_streams.hpp"
#include "magnetometer_insitu_calibration/pipeline/live_windows.hpp"
#include "magnetometer_insitu_calibration/preprocessing/despike.hpp"
#include "magnetometer_insitu_calibration/preprocessing/streaming_despike.hpp"
#include "magnetometer_insitu_calibration/simulation/remote_observatory.hpp"
#include "magnetometer_insitu_calibration/simulation/scalar_magnetometer.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

mic::WindowRecords window_at(double start_s, double value) {
  mic::WindowRecords w;
  w.start_s = start_s;
  w.expected_samples = 3;
  for (int i = 0; i < 3; ++i) {
    w.paired.time_s.push_back(start_s + i);
  }
  w.paired.reference_nT = mic::Readings::Constant(3, 3, value);
  w.paired.test_nT = mic::Readings::Constant(3, 3, value);
  return w;
}

}  // namespace

TEST(SlidingWindowBuffer, WindowsAlignedOnStepAndComplete) {
  mic::SlidingWindowBuffer buffer(100.0, 30.0, 1.0);
  std::vector<mic::WindowRecords> windows;
  const double t0 = 1000.0 + 7.0;  // not on a step boundary: the first window starts at 1020
  for (int k = 0; k < 300; ++k) {
    for (auto& w : buffer.push(t0 + k, Eigen::Vector3d::Constant(k), Eigen::Vector3d::Constant(-k))) {
      windows.push_back(std::move(w));
    }
  }
  ASSERT_GE(windows.size(), 6u);
  for (std::size_t i = 0; i < windows.size(); ++i) {
    EXPECT_DOUBLE_EQ(windows[i].start_s, 1020.0 + 30.0 * i);
    EXPECT_EQ(windows[i].expected_samples, 100u);
    ASSERT_EQ(windows[i].paired.size(), 100u);
    EXPECT_DOUBLE_EQ(windows[i].paired.time_s.front(), windows[i].start_s);
    EXPECT_DOUBLE_EQ(windows[i].paired.time_s.back(), windows[i].end_s());
    EXPECT_DOUBLE_EQ(windows[i].paired.test_nT(0, 0), -(windows[i].start_s - t0));
  }
  EXPECT_LE(buffer.buffered(), 101u);
  // Out of order and repeated stamps are ignored.
  EXPECT_TRUE(buffer.push(t0 + 10, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()).empty());
  EXPECT_EQ(buffer.out_of_order(), 1u);
}

TEST(SlidingWindowBuffer, JumpSkipsEmptyWindowsAndEmitsPartialOnes) {
  mic::SlidingWindowBuffer buffer(100.0, 50.0, 1.0);
  std::vector<mic::WindowRecords> windows;
  auto push = [&](double t) {
    for (auto& w : buffer.push(t, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero())) windows.push_back(std::move(w));
  };
  for (int k = 0; k < 120; ++k) push(k);        // 0..119
  for (int k = 0; k < 1000; ++k) push(1.0e6 + k);  // a jump of ~11.6 days
  // Before the jump: [0,100) complete; [50,150) and [100,200) partial; after: [1e6, 1e6+100) ...
  ASSERT_GE(windows.size(), 4u);
  EXPECT_DOUBLE_EQ(windows[0].start_s, 0.0);
  EXPECT_EQ(windows[1].paired.size(), 70u);
  EXPECT_EQ(windows[2].paired.size(), 20u);
  for (std::size_t i = 3; i < windows.size(); ++i) EXPECT_GE(windows[i].start_s, 1.0e6 - 100.0);
  EXPECT_GT(buffer.windows_skipped_empty(), 10000u);
}

TEST(StreamMonitor, ForwardJumpsStrayStampsAndConfirmedBackwardJumps) {
  using Jump = mic::StreamMonitor::Jump;
  mic::StreamMonitor m;
  const double threshold = 60.0;
  double t = 1.0e9;
  for (int k = 0; k < 10; ++k) EXPECT_EQ(m.observe(t += 1.0, 0.0, "f", threshold), Jump::kNone);
  EXPECT_EQ(m.observe(t += 3600.0, 0.0, "f", threshold), Jump::kForward);  // clock jumps ahead
  EXPECT_EQ(m.observe(t += 1.0, 0.0, "f", threshold), Jump::kNone);
  EXPECT_EQ(m.observe(0.0, 0.0, "f", threshold), Jump::kNone);  // one stray stamp
  EXPECT_EQ(m.observe(t += 1.0, 0.0, "f", threshold), Jump::kNone);
  EXPECT_EQ(m.stray, 1u);
  EXPECT_EQ(m.jumps_backward, 0u);
  EXPECT_EQ(m.observe(t - 7200.0, 0.0, "f", threshold), Jump::kNone);  // clock set back: first sample
  EXPECT_EQ(m.observe(t - 7199.0, 0.0, "f", threshold), Jump::kBackward);  // confirmed
  EXPECT_EQ(m.observe(t - 7198.0, 0.0, "f", threshold), Jump::kNone);
  EXPECT_EQ(m.jumps_forward, 1u);
  EXPECT_EQ(m.jumps_backward, 1u);
  EXPECT_EQ(m.stray, 1u);
  EXPECT_EQ(m.messages, 17u);
  EXPECT_DOUBLE_EQ(m.newest_stamp_s, t - 7198.0);
  // Small disorder is neither.
  EXPECT_EQ(m.observe(t - 7210.0, 0.0, "f", threshold), Jump::kNone);
  EXPECT_EQ(m.stray, 1u);
}

TEST(TemperatureBuffer, KeepsOrderedSamplesWithinItsSpanAndCopiesAWindow) {
  mic::TemperatureBuffer buffer(100.0);  // s
  for (int k = 0; k < 50; ++k) buffer.push(1000.0 + k, 20.0 + 0.1 * k);
  buffer.push(1020.0, 99.0);  // not later than the newest: ignored
  EXPECT_EQ(buffer.out_of_order(), 1u);
  EXPECT_EQ(buffer.buffered(), 50u);
  const mic::TemperatureSamples s = buffer.copy(1010.0, 1012.0);
  EXPECT_TRUE(s.recorded);
  ASSERT_EQ(s.time_s.size(), 3u);
  EXPECT_EQ(s.time_s.front(), 1010.0);
  EXPECT_DOUBLE_EQ(s.value_C.back(), 21.2);
  buffer.drop_before(1040.0);
  EXPECT_EQ(buffer.buffered(), 10u);
  buffer.push(1200.0, 25.0);  // 160 s after the oldest kept: everything older than 1100 s goes
  EXPECT_EQ(buffer.buffered(), 1u);
  buffer.reset();
  EXPECT_EQ(buffer.buffered(), 0u);
}

TEST(TemperatureOnGrid, InterpolatesAndHoldsTheEdgesOnlyWithinTheGap) {
  mic::TemperatureSamples s;
  s.recorded = true;
  s.time_s = {10.0, 13.0, 100.0};
  s.value_C = {20.0, 21.5, 30.0};
  const std::vector<double> at = {5.0, 7.0, 11.5, 60.0, 103.0, 106.0};
  const Eigen::VectorXd g = mic::temperature_on_grid(s, at, 4.0);
  EXPECT_TRUE(std::isnan(g(0)));   // 5 s before the first sample: more than 4 s
  EXPECT_EQ(g(1), 20.0);           // 3 s before: held
  EXPECT_DOUBLE_EQ(g(2), 20.75);   // linear
  EXPECT_TRUE(std::isnan(g(3)));   // inside an 87 s gap
  EXPECT_EQ(g(4), 30.0);           // 3 s after the last: held
  EXPECT_TRUE(std::isnan(g(5)));
  mic::TemperatureSamples none;
  none.recorded = true;
  EXPECT_TRUE(mic::temperature_on_grid(none, at, 4.0).array().isNaN().all());
}

TEST(CoincidentWindows, ReleasesAStartWhenEveryInstrumentHasIt) {
  mic::CoincidentWindows groups(3);
  EXPECT_TRUE(groups.add(0, window_at(0.0, 0.0)).empty());
  EXPECT_TRUE(groups.add(2, window_at(0.0, 2.0)).empty());
  EXPECT_EQ(groups.pending(), 2u);
  const auto released = groups.add(1, window_at(0.0, 1.0));
  ASSERT_EQ(released.size(), 3u);
  EXPECT_EQ(groups.pending(), 0u);
  for (std::size_t c = 0; c < 3; ++c) {
    EXPECT_EQ(released[c].channel, c);
    ASSERT_NE(released[c].window.third, nullptr);
    EXPECT_EQ(released[c].mate_channel, (c + 1) % 3);  // the next instrument in order
    // The mate's samples are its own window's test samples.
    EXPECT_EQ(released[c].window.third->values_nT(0, 0), static_cast<double>((c + 1) % 3));
    EXPECT_EQ(released[c].window.paired.test_nT(0, 0), static_cast<double>(c));
  }
}

TEST(CoincidentWindows, TheThirdIsTheMatesTestAtItsCompleteEpochs) {
  // An epoch the mate's reference lacks (a spike taken out) is one the hat cannot use: NaN in
  // the third, the mate's test values elsewhere, on its window's epochs.
  mic::CoincidentWindows groups(2);
  mic::WindowRecords mate = window_at(0.0, 1.0);
  mate.paired.reference_nT(1, 2) = std::numeric_limits<double>::quiet_NaN();
  mate.paired.test_nT(2, 0) = 5.0;
  EXPECT_TRUE(groups.add(1, std::move(mate)).empty());
  const auto released = groups.add(0, window_at(0.0, 0.0));
  ASSERT_EQ(released.size(), 2u);
  const mic::VectorRecord& third = *released[0].window.third;
  EXPECT_EQ(third.time_s, (std::vector<double>{0.0, 1.0, 2.0}));
  EXPECT_EQ(third.values_nT(0, 1), 1.0);
  EXPECT_TRUE(third.values_nT.row(1).array().isNaN().all());
  EXPECT_EQ(third.values_nT(2, 0), 5.0);
}

TEST(CoincidentWindows, ASilentInstrumentHoldsTheOthersOneStepAtMost) {
  mic::CoincidentWindows groups(2);
  EXPECT_TRUE(groups.add(0, window_at(0.0, 0.0)).empty());
  // Instrument 1 never completes [0, ...): when 0 completes the next start, the first goes alone.
  const auto released = groups.add(0, window_at(300.0, 0.0));
  ASSERT_EQ(released.size(), 1u);
  EXPECT_EQ(released[0].window.start_s, 0.0);
  EXPECT_EQ(released[0].window.third, nullptr);
  EXPECT_EQ(groups.pending(), 1u);  // [300, ...) waits for instrument 1
  // Instrument 1 comes back with a later window: [300, ...) is released without it, then the
  // newest start waits for instrument 0.
  const auto later = groups.add(1, window_at(600.0, 1.0));
  ASSERT_EQ(later.size(), 1u);
  EXPECT_EQ(later[0].window.start_s, 300.0);
  EXPECT_EQ(later[0].channel, 0u);
  EXPECT_EQ(later[0].window.third, nullptr);
  const auto both = groups.add(0, window_at(600.0, 0.0));
  ASSERT_EQ(both.size(), 2u);
  EXPECT_NE(both[0].window.third, nullptr);
  EXPECT_NE(both[1].window.third, nullptr);
}

TEST(CoincidentWindows, AResetInstrumentIsForgotten) {
  mic::CoincidentWindows groups(2);
  EXPECT_TRUE(groups.add(1, window_at(3600.0, 1.0)).empty());
  groups.reset(1);  // its stamps went back: its waiting window is dropped
  EXPECT_EQ(groups.pending(), 0u);
  EXPECT_TRUE(groups.add(0, window_at(0.0, 0.0)).empty());  // not released by 1's old start
}


namespace {

/// A record of `n` samples at 1 Hz with a slow field, white noise, one-sample spikes every 97
/// samples and a few missing values: what the despikers see.
mic::Readings spiky_readings(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 random(seed);
  std::normal_distribution<double> normal(0.0, 0.05);
  mic::Readings x(static_cast<Eigen::Index>(n), 3);
  for (std::size_t i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) {
      x(static_cast<Eigen::Index>(i), c) = 20.0 * std::sin(2.0 * M_PI * (static_cast<double>(i) / 600.0 + c)) + normal(random);
    }
  }
  for (std::size_t i = 13; i < n; i += 97) x(static_cast<Eigen::Index>(i), static_cast<int>(i % 3)) += 40.0;
  for (std::size_t i = 500; i < n; i += 1000) x(static_cast<Eigen::Index>(i), 1) = std::numeric_limits<double>::quiet_NaN();
  return x;
}

bool same_values(const mic::Readings& a, const mic::Readings& b) {
  if (a.rows() != b.rows()) return false;
  for (Eigen::Index i = 0; i < a.rows(); ++i)
    for (int c = 0; c < 3; ++c) {
      const double u = a(i, c), v = b(i, c);
      if (!(u == v || (std::isnan(u) && std::isnan(v)))) return false;
    }
  return true;
}

}  // namespace

TEST(StreamingDespiker, TheStreamHoldsExactlyTheBatchDespikedValues) {
  const mic::Readings raw = spiky_readings(5000, 7);
  mic::Readings batch = raw;
  const std::size_t batch_spikes = mic::despike(batch, mic::DespikeSettings{});
  ASSERT_GE(batch_spikes, 50u);
  mic::StreamingDespiker streaming;
  mic::Readings live(raw.rows(), 3);
  Eigen::Index next = 0;
  for (Eigen::Index i = 0; i < raw.rows(); ++i) {
    mic::StreamingDespiker::Sample out;
    if (streaming.push(static_cast<double>(i), raw.row(i).transpose(), out)) {
      EXPECT_EQ(out.time_s, static_cast<double>(next));  // in order, 2w samples late
      live.row(next++) = out.value_nT.transpose();
    }
  }
  EXPECT_EQ(next, raw.rows() - static_cast<Eigen::Index>(streaming.delay_samples()));
  EXPECT_EQ(streaming.held(), streaming.delay_samples());
  for (const mic::StreamingDespiker::Sample& out : streaming.flush()) live.row(next++) = out.value_nT.transpose();
  ASSERT_EQ(next, raw.rows());
  EXPECT_TRUE(same_values(live, batch));
  EXPECT_EQ(streaming.spikes(), batch_spikes);
  // After a reset the next sample starts a new stream, as a new record would.
  streaming.reset();
  mic::StreamingDespiker::Sample unused;
  EXPECT_FALSE(streaming.push(0.0, Eigen::Vector3d::Zero(), unused));
}

TEST(LiveCalibrationStreams, WindowsHoldTheOfflineWindowsOfTheSameSamples) {
  // A 1 Hz pair with spikes in both records pushed sample by sample, despiking on, hourly windows
  // every half hour: every completed window, put on its grid, holds exactly the offline
  // preparation's window of the same epochs (despiked at the records' own rate, paired, on the
  // grid). The per-window stage then gives both the same calibration.
  mic::SimulationSettings s;
  s.seed = 17;
  s.duration_s = 4.0 * 3600.0;
  s.start_time_s = 1747180800.0;  // a whole multiple of the step
  mic::SimulatedPair pair = mic::simulate_pair(s);
  for (std::size_t i = 100; i < pair.reference.size(); i += 701) pair.reference.values_nT(static_cast<Eigen::Index>(i), 0) += 30.0;
  for (std::size_t i = 250; i < pair.test.size(); i += 907) pair.test.values_nT(static_cast<Eigen::Index>(i), 2) -= 30.0;
  mic::LiveStreamSettings live;
  live.window_s = 3600.0;
  live.step_s = 1800.0;
  mic::LiveCalibrationStreams streams(live, {{"test", false}}, false);
  std::vector<mic::WindowRecords> windows;
  for (std::size_t i = 0; i < pair.reference.size(); ++i) {
    for (auto& c : streams.push_reference(pair.reference.time_s[i], pair.reference.values_nT.row(static_cast<Eigen::Index>(i)).transpose()))
      windows.push_back(std::move(c.window));
    for (auto& c : streams.push_test(0, pair.test.time_s[i], pair.test.values_nT.row(static_cast<Eigen::Index>(i)).transpose()))
      windows.push_back(std::move(c.window));
  }
  ASSERT_EQ(windows.size(), 6u);  // the 7th ends with the record: no sample after its end
  EXPECT_GT(streams.reference_spikes(), 10u);
  EXPECT_GT(streams.test(0).despiker.spikes(), 10u);
  const mic::PreparedPair prepared = mic::prepare_pair(pair.reference, pair.test, mic::PreprocessSettings{});
  mic::WindowCalibrator calibrator{mic::WindowCalibrationSettings{}};
  for (const mic::WindowRecords& w : windows) {
    const std::size_t first = static_cast<std::size_t>(std::llround(w.start_s - prepared.paired.time_s[0]));
    const mic::WindowRecords offline = mic::window_records(prepared, first, w.expected_samples, 60.0);
    mic::PairedRecord a = w.paired, b = offline.paired;
    mic::regularize(a, 1.0);
    mic::regularize(b, 1.0);
    EXPECT_EQ(a.time_s, b.time_s) << w.start_s;
    EXPECT_TRUE(same_values(a.reference_nT, b.reference_nT)) << w.start_s;
    EXPECT_TRUE(same_values(a.test_nT, b.test_nT)) << w.start_s;
  }
  const mic::CalibrationWindow l = calibrator.calibrate(windows[2]);
  const std::size_t first = static_cast<std::size_t>(std::llround(windows[2].start_s - prepared.paired.time_s[0]));
  const mic::CalibrationWindow o = calibrator.calibrate(mic::window_records(prepared, first, 3600, 60.0));
  EXPECT_EQ(l.estimate.n, o.estimate.n);
  EXPECT_EQ(l.estimate.n_covariance, o.estimate.n_covariance);
  EXPECT_EQ(l.missing(), o.missing());
}

TEST(LiveCalibrationStreams, ARemoteStreamGivesTheWindowsTheOfflineRemote) {
  // The pair and a remote observatory (with spikes of its own) pushed sample by sample: every
  // completed window carries the remote's samples of its epochs as calibrate_records prepares
  // --remote against the reference (despiked, paired, on the grid), and the per-window stage
  // gives both the same remote-reference calibration.
  mic::SimulationSettings s;
  s.seed = 23;
  s.duration_s = 3.0 * 3600.0;
  s.start_time_s = 1747180800.0;
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::VectorRecord remote = mic::simulate_remote_observatory(s, pair, mic::RemoteObservatorySettings{});
  for (std::size_t i = 300; i < remote.size(); i += 613) remote.values_nT(static_cast<Eigen::Index>(i), 1) += 40.0;
  mic::LiveStreamSettings live;
  live.window_s = 3600.0;
  live.step_s = 1800.0;
  mic::LiveCalibrationStreams streams(live, {{"test", false}}, false);
  streams.add_remote("/remote/magnetic_field");
  std::vector<mic::WindowRecords> windows;
  for (std::size_t i = 0; i < pair.reference.size(); ++i) {
    const auto row = [i](const mic::VectorRecord& r) { return Eigen::Vector3d(r.values_nT.row(static_cast<Eigen::Index>(i)).transpose()); };
    for (auto& c : streams.push_reference(pair.reference.time_s[i], row(pair.reference))) windows.push_back(std::move(c.window));
    streams.push_remote(remote.time_s[i], row(remote));
    for (auto& c : streams.push_test(0, pair.test.time_s[i], row(pair.test))) windows.push_back(std::move(c.window));
  }
  ASSERT_EQ(windows.size(), 4u);
  EXPECT_GT(streams.remote()->spikes(), 10u);
  mic::CalibrationSettings settings;
  const mic::PreparedPair prepared = mic::prepare_pair(pair.reference, pair.test, settings.preprocess);
  const mic::PreparedSides sides = mic::prepare_sides(pair.reference, prepared, {nullptr, &remote}, settings);
  mic::WindowCalibrator calibrator{settings.window};
  for (const mic::WindowRecords& w : windows) {
    ASSERT_TRUE(w.remote) << w.start_s;
    const std::size_t first = static_cast<std::size_t>(std::llround(w.start_s - prepared.paired.time_s[0]));
    const mic::WindowRecords offline = mic::window_records(prepared, first, w.expected_samples, 60.0, &sides);
    ASSERT_TRUE(offline.remote);
    EXPECT_EQ(w.remote->time_s, offline.remote->time_s) << w.start_s;
    EXPECT_TRUE(same_values(w.remote->values_nT, offline.remote->values_nT)) << w.start_s;
    const mic::CalibrationWindow l = calibrator.calibrate(w);
    const mic::CalibrationWindow o = calibrator.calibrate(offline);
    EXPECT_TRUE(l.estimate.remote.used) << l.estimate.remote.text;
    EXPECT_EQ(l.estimate.n, o.estimate.n) << w.start_s;
  }
}

TEST(LiveCalibrationStreams, AWindowWaitsForALateRemoteAndNotForASilentOne) {
  // The remote's samples arrive two hours (stamp time) after the pair's, as a neighbouring
  // observatory's files do: each window waits for them (remote_max_wait_s, not the pairs' own
  // pairing_max_wait_s) and carries exactly the offline remote. A remote that never speaks holds
  // a window only until the pair is remote_max_wait_s past its end, and the window says why.
  mic::SimulationSettings s;
  s.seed = 29;
  s.duration_s = 3.0 * 3600.0;
  s.start_time_s = 1747180800.0;
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  const mic::VectorRecord remote = mic::simulate_remote_observatory(s, pair, mic::RemoteObservatorySettings{});
  mic::LiveStreamSettings live;
  live.window_s = 3600.0;
  live.step_s = 1800.0;
  const std::size_t lag = 7200;  // samples = s
  const auto row = [](const mic::VectorRecord& r, std::size_t i) {
    return Eigen::Vector3d(r.values_nT.row(static_cast<Eigen::Index>(i)).transpose());
  };
  for (bool silent : {false, true}) {
    live.remote_max_wait_s = silent ? 1200.0 : 21600.0;
    mic::LiveCalibrationStreams streams(live, {{"test", false}}, false);
    streams.add_remote("/remote/magnetic_field");
    std::vector<mic::WindowRecords> windows;
    std::vector<double> released_at;  // the pair's newest stamp when each window came out
    const auto take = [&](std::vector<mic::LiveCalibrationStreams::Completed> done, double now) {
      for (auto& c : done) {
        windows.push_back(std::move(c.window));
        released_at.push_back(now);
      }
    };
    const std::size_t n = pair.reference.size();
    for (std::size_t i = 0; i < n; ++i) {
      const double now = pair.reference.time_s[i];
      take(streams.push_reference(now, row(pair.reference, i)), now);
      take(streams.push_test(0, now, row(pair.test, i)), now);
      if (!silent && i >= lag) take(streams.push_remote(remote.time_s[i - lag], row(remote, i - lag)), now);
    }
    if (!silent) {  // the remote's last two hours, after the pair's end
      EXPECT_LE(windows.size(), 1u) << "the windows waited for the remote";
      for (std::size_t i = n - lag; i < n; ++i) take(streams.push_remote(remote.time_s[i], row(remote, i)), 0.0);
    }
    mic::CalibrationSettings settings;
    const mic::PreparedPair prepared = mic::prepare_pair(pair.reference, pair.test, settings.preprocess);
    const mic::PreparedSides sides = mic::prepare_sides(pair.reference, prepared, {nullptr, &remote}, settings);
    if (!silent) {
      ASSERT_EQ(windows.size(), 4u);
      for (const mic::WindowRecords& w : windows) {
        ASSERT_TRUE(w.remote) << w.start_s;
        EXPECT_EQ(w.remote_late, "") << w.start_s;
        const std::size_t first = static_cast<std::size_t>(std::llround(w.start_s - prepared.paired.time_s[0]));
        const mic::WindowRecords offline = mic::window_records(prepared, first, w.expected_samples, 60.0, &sides);
        EXPECT_EQ(w.remote->time_s, offline.remote->time_s) << w.start_s;
        EXPECT_TRUE(same_values(w.remote->values_nT, offline.remote->values_nT)) << w.start_s;
      }
    } else {
      // The windows the pair has left remote_max_wait_s behind, each once it is, without a remote.
      ASSERT_EQ(windows.size(), 4u);
      for (std::size_t k = 0; k < windows.size(); ++k) {
        EXPECT_GT(released_at[k] - windows[k].end_s(), live.remote_max_wait_s) << k;
        EXPECT_LE(released_at[k] - windows[k].end_s(), live.remote_max_wait_s + 60.0) << k;
        EXPECT_TRUE(!windows[k].remote || windows[k].remote->time_s.empty()) << k;
        EXPECT_EQ(windows[k].remote_late,
                  "no remote sample had come when the pair was 1200 s past the window's end")
            << k;
      }
    }
  }
}

TEST(LiveCalibrationStreams, AScalarStreamGivesTheWindowsTheOfflineScalarCheck) {
  // The pair (its reference reading 0.3 % high along every axis) and a scalar magnetometer every
  // second, 0.37 s off the pair's stamps, pushed sample by sample: every completed window carries
  // the scalar's samples around it, the per-window stage gives it the scalar check that
  // calibrate_records gives the same window from the whole scalar record, and that check finds
  // the reference's scale 1.003 within its interval.
  constexpr double kScale = 1.003;
  mic::SimulationSettings s;
  s.seed = 29;
  s.duration_s = 5.0 * 3600.0 + 60.0;
  s.start_time_s = 1747180800.0;
  mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::ScalarMagnetometerSettings sm;
  sm.seed = 31;
  const mic::ScalarRecord scalar = mic::simulate_scalar_magnetometer(pair, sm);
  pair.reference.values_nT *= kScale;
  mic::LiveStreamSettings live;
  live.window_s = 3.0 * 3600.0;
  live.step_s = 3600.0;
  mic::LiveCalibrationStreams streams(live, {{"test", false}}, false);
  streams.add_scalar("/scalar/field");
  std::vector<mic::WindowRecords> windows;
  std::size_t next_scalar = 0;
  for (std::size_t i = 0; i < pair.reference.size(); ++i) {
    const auto row = [i](const mic::VectorRecord& r) { return Eigen::Vector3d(r.values_nT.row(static_cast<Eigen::Index>(i)).transpose()); };
    // F as it arrives: every sample stamped up to the pair's (a scalar lagging the pair would
    // miss a window's last samples).
    for (; next_scalar < scalar.size() && scalar.time_s[next_scalar] <= pair.reference.time_s[i] + 1.0; ++next_scalar) {
      ASSERT_TRUE(streams.push_scalar(scalar.time_s[next_scalar], scalar.value_nT[next_scalar]));
    }
    for (auto& c : streams.push_reference(pair.reference.time_s[i], row(pair.reference))) windows.push_back(std::move(c.window));
    for (auto& c : streams.push_test(0, pair.test.time_s[i], row(pair.test))) windows.push_back(std::move(c.window));
  }
  EXPECT_FALSE(streams.push_scalar(scalar.time_s[10], 50000.0));  // a stamp gone back: refused
  EXPECT_EQ(streams.scalar()->refused, 1u);
  // Kept: what the next window (from 3 h) needs, its margin included, not the whole 5 h.
  EXPECT_LT(streams.scalar()->samples.size(), static_cast<std::size_t>(2.0 * 3600.0 + 300.0));
  ASSERT_EQ(windows.size(), 3u);
  mic::CalibrationSettings settings;
  const mic::PreparedPair prepared = mic::prepare_pair(pair.reference, pair.test, settings.preprocess);
  const mic::PreparedSides sides = mic::prepare_sides(pair.reference, prepared, {nullptr, nullptr, &scalar}, settings);
  mic::WindowCalibrator calibrator{settings.window};
  for (const mic::WindowRecords& w : windows) {
    ASSERT_TRUE(w.scalar) << w.start_s;
    ASSERT_GT(w.scalar->size(), static_cast<std::size_t>(live.window_s)) << w.start_s;
    EXPECT_LE(w.scalar->time_s.front(), std::max(w.start_s - 60.0, scalar.time_s.front()));
    EXPECT_GT(w.scalar->time_s.back(), w.end_s());  // what had arrived when the window completed
    const std::size_t first = static_cast<std::size_t>(std::llround(w.start_s - prepared.paired.time_s[0]));
    const mic::CalibrationWindow l = calibrator.calibrate(w);
    const mic::CalibrationWindow o = calibrator.calibrate(mic::window_records(prepared, first, w.expected_samples, 60.0, &sides));
    ASSERT_TRUE(l.scalar.assessed) << l.scalar.text;
    EXPECT_EQ(l.scalar.reference_scale, o.scalar.reference_scale) << w.start_s;
    EXPECT_EQ(l.scalar.reference_scale_ci95, o.scalar.reference_scale_ci95) << w.start_s;
    EXPECT_NEAR(l.scalar.reference_scale, kScale, l.scalar.reference_scale_ci95) << l.scalar.text;
  }
}
