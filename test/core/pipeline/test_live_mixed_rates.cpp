// Live streams of two rates or two phases (pipeline/live_streams.hpp, epoch_alignment.hpp): a
// 1 s reference beside a 10 Hz test, a 1 s remote beside a 10 Hz pair, and one rate stamped at two
// phases. Each stream is low-passed onto the estimation epochs before pairing, as calibrate_records
// prepares the same records; every window must carry the values the offline preparation gives it.
// And the period and phase a stream monitor measures on a stream's stamps (live_windows.hpp),
// which tell a stream at another rate than its parameter says, or stamped where nothing pairs.
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/time_steps.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/pipeline/live_streams.hpp"
#include "magnetometer_insitu_calibration/pipeline/live_windows.hpp"
#include "magnetometer_insitu_calibration/preprocessing/gap_filling.hpp"
#include "magnetometer_insitu_calibration/simulation/remote_observatory.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include "ten_hz_station.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <tuple>
#include <vector>

namespace mic = magnetometer_insitu_calibration;
using mic::test::every_tenth;

namespace {

/// Three hours of a LEMI-025 pair at 10 Hz, with 25 spikes of 50 nT in either instrument: the
/// despikers work too.
mic::SimulationSettings three_hours_with_spikes(std::uint64_t seed) {
  mic::SimulationSettings s = mic::test::ten_hz_station(seed, 3.0);
  s.spikes_per_day = 200;
  return s;
}

/// Every sample of the records pushed in time order, as the messages of their topics arrive (the
/// reference's first at a stamp they share, then the tests' in order, then the remote's);
/// returns the windows completed, with the test each belongs to.
std::vector<std::pair<std::size_t, mic::WindowRecords>> push_in_time_order(
    mic::LiveCalibrationStreams& streams, const mic::VectorRecord& reference,
    const std::vector<const mic::VectorRecord*>& tests, const mic::VectorRecord* remote) {
  constexpr int kReference = -1, kRemote = 1 << 20;  // else the test's index
  std::vector<std::tuple<double, int, std::size_t>> order;
  for (std::size_t i = 0; i < reference.size(); ++i) order.emplace_back(reference.time_s[i], kReference, i);
  for (std::size_t k = 0; k < tests.size(); ++k) {
    for (std::size_t i = 0; i < tests[k]->size(); ++i) order.emplace_back(tests[k]->time_s[i], static_cast<int>(k), i);
  }
  if (remote != nullptr) {
    for (std::size_t i = 0; i < remote->size(); ++i) order.emplace_back(remote->time_s[i], kRemote, i);
  }
  std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) {
    return std::get<0>(a) < std::get<0>(b) || (std::get<0>(a) == std::get<0>(b) && std::get<1>(a) < std::get<1>(b));
  });
  std::vector<std::pair<std::size_t, mic::WindowRecords>> windows;
  for (const auto& [time, stream, i] : order) {
    const auto row = [i = i](const mic::VectorRecord& r) {
      return Eigen::Vector3d(r.values_nT.row(static_cast<Eigen::Index>(i)).transpose());
    };
    std::vector<mic::LiveCalibrationStreams::Completed> done;
    if (stream == kReference) done = streams.push_reference(time, row(reference));
    else if (stream == kRemote) done = streams.push_remote(time, row(*remote));
    else done = streams.push_test(static_cast<std::size_t>(stream), time, row(*tests[static_cast<std::size_t>(stream)]));
    for (auto& c : done) windows.emplace_back(c.test, std::move(c.window));
  }
  return windows;
}

/// The windows of one test and reference pushed in time order.
std::vector<mic::WindowRecords> push_in_time_order(mic::LiveCalibrationStreams& streams, const mic::VectorRecord& reference,
                                                   const mic::VectorRecord& test, const mic::VectorRecord* remote) {
  std::vector<mic::WindowRecords> windows;
  for (auto& [index, window] : push_in_time_order(streams, reference, {&test}, remote)) windows.push_back(std::move(window));
  return windows;
}

/// Largest |a - b| over the finite values, nT; infinity when their shapes or NaNs differ.
double largest_difference(const mic::Readings& a, const mic::Readings& b) {
  if (a.rows() != b.rows()) return std::numeric_limits<double>::infinity();
  double largest = 0.0;
  for (Eigen::Index i = 0; i < a.rows(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const double u = a(i, c), v = b(i, c);
      if (std::isnan(u) != std::isnan(v)) return std::numeric_limits<double>::infinity();
      if (!std::isnan(u)) largest = std::max(largest, std::abs(u - v));
    }
  }
  return largest;
}

/// Each live window against the offline window of the same epochs, both on their grid: times,
/// values (the streaming and batch filters agree to rounding) and, with a remote, its samples;
/// then the same n.
void expect_offline_windows(const std::vector<mic::WindowRecords>& windows, const mic::PreparedPair& prepared,
                            const mic::PreparedSides* sides) {
  const mic::CalibrationSettings settings;
  mic::WindowCalibrator calibrator{settings.window};
  for (const mic::WindowRecords& w : windows) {
    const auto first = static_cast<std::size_t>(std::llround((w.start_s - prepared.paired.time_s[0]) / w.period_s));
    const mic::WindowRecords offline = mic::window_records(prepared, first, w.expected_samples, 60.0, sides);
    mic::PairedRecord a = w.paired, b = offline.paired;  // on the grid, a NaN in either masking both
    mic::regularize(a, w.period_s);
    mic::regularize(b, w.period_s);
    EXPECT_EQ(a.time_s, b.time_s) << w.start_s;
    EXPECT_LT(largest_difference(a.reference_nT, b.reference_nT), 1e-9) << w.start_s;
    EXPECT_LT(largest_difference(a.test_nT, b.test_nT), 1e-9) << w.start_s;
    ASSERT_EQ(w.decimation.has_value(), offline.decimation.has_value());
    if (w.decimation) EXPECT_DOUBLE_EQ(w.decimation->output_period_s, offline.decimation->output_period_s);
    if (sides != nullptr && sides->remote) {
      ASSERT_TRUE(w.remote && offline.remote) << w.start_s;
      EXPECT_EQ(w.remote->time_s, offline.remote->time_s) << w.start_s;
      EXPECT_LT(largest_difference(w.remote->values_nT, offline.remote->values_nT), 1e-9) << w.start_s;
    }
    const mic::CalibrationWindow live_result = calibrator.calibrate(w), offline_result = calibrator.calibrate(offline);
    ASSERT_EQ(live_result.estimate.quality, mic::Quality::kOk) << live_result.estimate.quality_text;
    EXPECT_LT((live_result.estimate.n - offline_result.estimate.n).cwiseAbs().maxCoeff(), 1e-9) << w.start_s;
    if (sides != nullptr && sides->remote) EXPECT_TRUE(live_result.estimate.remote.used) << live_result.estimate.remote.text;
  }
}

}  // namespace

// An observatory's 1 s reference beside a 10 Hz LEMI-025 under test: each stream through the
// Gaussian FIR onto whole seconds, then paired, as calibrate_records prepares them.
TEST(LiveMixedRates, AOneSecondReferenceBesideATenHertzTestGivesTheOfflineWindows) {
  const mic::SimulatedPair pair = mic::simulate_pair(three_hours_with_spikes(41));
  const mic::VectorRecord reference = every_tenth(pair.reference, 3);
  mic::LiveStreamSettings live;
  live.input_period_s = 1.0;
  live.test_input_period_s = 0.1;
  live.window_s = 3600.0;
  live.step_s = 1800.0;
  EXPECT_EQ(live.test_plan().alignment, mic::EpochAlignment::kEachFiltered);
  mic::LiveCalibrationStreams streams(live, {{"test", false}}, false);
  const std::vector<mic::WindowRecords> windows = push_in_time_order(streams, reference, pair.test, nullptr);
  // Starts 0.5, 1 and 1.5 h: the first window lacks the kernel's first seconds, the 2 h one its last.
  ASSERT_EQ(windows.size(), 3u);
  EXPECT_GT(streams.test(0).despiker.spikes() + streams.reference_spikes(), 5u);

  mic::PreprocessReport report;
  const mic::PreparedPair prepared = mic::prepare_pair(reference, pair.test, mic::PreprocessSettings{}, &report);
  ASSERT_EQ(report.alignment, mic::EpochAlignment::kEachFiltered);
  expect_offline_windows(windows, prepared, nullptr);
}

// A 10 Hz pair with a neighbouring observatory's 1 s record as its remote reference: the pair is
// paired then decimated, the remote and the reference each filtered onto whole seconds, as
// calibrate_records --remote prepares them.
TEST(LiveMixedRates, AOneSecondRemoteBesideATenHertzPairGivesTheOfflineRemote) {
  mic::SimulationSettings s = three_hours_with_spikes(43);
  s.keep_clean_field = true;  // the remote sees it
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  const mic::VectorRecord remote = every_tenth(mic::simulate_remote_observatory(s, pair, mic::RemoteObservatorySettings{}), 3);
  mic::LiveStreamSettings live;
  live.input_period_s = 0.1;
  live.remote_input_period_s = 1.0;
  live.window_s = 3600.0;
  live.step_s = 1800.0;
  mic::LiveCalibrationStreams streams(live, {{"test", false}}, false);
  streams.add_remote("/remote/magnetic_field");
  EXPECT_EQ(streams.test(0).alignment, mic::EpochAlignment::kPairedThenDecimated);
  EXPECT_EQ(streams.remote()->alignment(), mic::EpochAlignment::kEachFiltered);
  const std::vector<mic::WindowRecords> windows = push_in_time_order(streams, pair.reference, pair.test, &remote);
  ASSERT_EQ(windows.size(), 3u);

  const mic::CalibrationSettings settings;
  const mic::PreparedPair prepared = mic::prepare_pair(pair.reference, pair.test, settings.preprocess);
  const mic::PreparedSides sides = mic::prepare_sides(pair.reference, prepared, {nullptr, &remote}, settings);
  expect_offline_windows(windows, prepared, &sides);
}

// One rate, two phases: a 1 s test stamped 0.3 s after the reference's seconds pairs with nothing
// by stamp; with stamps_apart each stream is filtered onto whole seconds first.
TEST(LiveMixedRates, StreamsStampedAtTwoPhasesAreFilteredOntoCommonEpochs) {
  const mic::SimulatedPair pair = mic::simulate_pair(three_hours_with_spikes(47));
  const mic::VectorRecord reference = every_tenth(pair.reference, 3), test = every_tenth(pair.test, 6);
  ASSERT_NEAR(test.time_s[0] - reference.time_s[0], 0.3, 1e-6);
  mic::LiveStreamSettings live;
  live.window_s = 3600.0;
  live.step_s = 1800.0;
  {
    mic::LiveCalibrationStreams by_stamp(live, {{"test", false}}, false);
    EXPECT_TRUE(push_in_time_order(by_stamp, reference, test, nullptr).empty());
    EXPECT_EQ(by_stamp.test(0).counters().paired, 0u);
  }
  live.stamps_apart = true;
  mic::LiveCalibrationStreams streams(live, {{"test", false}}, false);
  const std::vector<mic::WindowRecords> windows = push_in_time_order(streams, reference, test, nullptr);
  ASSERT_EQ(windows.size(), 3u);
  mic::PreprocessReport report;
  const mic::PreparedPair prepared = mic::prepare_pair(reference, test, mic::PreprocessSettings{}, &report);
  ASSERT_EQ(report.alignment, mic::EpochAlignment::kEachFiltered);
  expect_offline_windows(windows, prepared, nullptr);
}

// Two tests against one 1 s reference, each at its own rate (a list of tests, each with its own
// input_period): the 10 Hz one filtered onto whole seconds, the 1 s one paired by stamp; each
// test's windows are those of the offline preparation of its own pair.
TEST(LiveMixedRates, TwoTestsOfTwoRatesBesideOneReferenceGiveTheirOfflineWindows) {
  const mic::SimulatedPair pair = mic::simulate_pair(three_hours_with_spikes(53));
  const mic::VectorRecord reference = every_tenth(pair.reference, 3), slow_test = every_tenth(pair.test, 3);
  mic::LiveStreamSettings live;
  live.window_s = 3600.0;
  live.step_s = 1800.0;
  mic::LiveCalibrationStreams streams(live, {{"lemi", false, 0.1}, {"fge", false, 0.0}}, false);
  EXPECT_EQ(streams.test(0).alignment, mic::EpochAlignment::kEachFiltered);
  EXPECT_EQ(streams.test(1).alignment, mic::EpochAlignment::kPairedStamps);
  const auto windows = push_in_time_order(streams, reference, {&pair.test, &slow_test}, nullptr);
  const mic::VectorRecord* tests[] = {&pair.test, &slow_test};
  for (std::size_t k = 0; k < 2; ++k) {
    SCOPED_TRACE("test " + std::to_string(k));
    std::vector<mic::WindowRecords> own;
    for (const auto& [index, window] : windows) {
      if (index == k) own.push_back(window);
    }
    ASSERT_GE(own.size(), 3u);
    expect_offline_windows(own, mic::prepare_pair(reference, *tests[k], mic::PreprocessSettings{}), nullptr);
  }
  // A test whose period would put its windows at another estimation period is refused.
  try {
    mic::LiveCalibrationStreams minute(live, {{"a", false, 0.0}, {"b", false, 60.0}}, false);
    FAIL() << "a 60 s test beside 1 s windows accepted";
  } catch (const mic::InputError& e) {
    EXPECT_EQ(e.where(), "input_period_s");
    EXPECT_NE(e.problem().find("of 60 s puts the test's pairs with the reference every 60 s, the others' every 1 s"),
              std::string::npos)
        << e.problem();
  }
}

// The three-cornered hat compares the instruments' spectra above the band, where the Gaussian
// FIR's gain falls (0.1 in power at 0.25 Hz for 1 s epochs): a third filtered where the pair is
// not, or tests of a list filtered unlike, are refused rather than show the filter as noise.
TEST(LiveMixedRates, TheHatRefusesInstrumentsFilteredUnlike) {
  const mic::SimulatedPair pair = mic::simulate_pair(three_hours_with_spikes(59));
  const mic::VectorRecord reference = every_tenth(pair.reference, 3), test = every_tenth(pair.test, 3);
  try {  // offline: a 1 s pair paired by stamp, a 10 Hz third filtered onto the seconds
    mic::calibrate_records(reference, test, mic::CalibrationSettings{}, {&pair.test, nullptr, nullptr});
    FAIL() << "a third filtered unlike the pair accepted";
  } catch (const mic::InputError& e) {
    EXPECT_EQ(e.where(), "--third");
    EXPECT_NE(e.problem().find("the three-cornered hat needs the three records filtered alike"), std::string::npos)
        << e.problem();
  }
  mic::LiveStreamSettings live;
  try {  // live: two tests of a list at two rates, windows released together for the hat
    mic::LiveCalibrationStreams streams(live, {{"fge", false, 0.0}, {"lemi", false, 0.1}}, true);
    FAIL() << "tests filtered unlike accepted for the hat";
  } catch (const mic::InputError& e) {
    EXPECT_EQ(e.where(), "input_period_s");
    EXPECT_NE(e.problem().find("the three-cornered hat needs the tests filtered alike"), std::string::npos) << e.problem();
  }
  // Filtered alike, both are accepted: the 10 Hz third beside a 10 Hz pair, two 10 Hz tests.
  EXPECT_NO_THROW(mic::prepare_sides(pair.reference, mic::prepare_pair(pair.reference, pair.test, mic::PreprocessSettings{}),
                                     {&pair.test, nullptr, nullptr}, mic::CalibrationSettings{}));
  EXPECT_NO_THROW(mic::LiveCalibrationStreams(live, {{"a", false, 0.1}, {"b", false, 0.1}}, true));
}

// Periods that cannot give the windows are refused by name before any sample.
TEST(LiveMixedRates, PeriodsThatCannotGiveWindowsAreRefusedByName) {
  const auto where = [](const mic::LiveStreamSettings& live, bool remote) -> std::string {
    try {
      mic::LiveCalibrationStreams streams(live, {{"test", false}}, false);
      if (remote) streams.add_remote("/remote");
    } catch (const mic::InputError& e) {
      return e.where() + ": " + e.problem();
    }
    return "accepted";
  };
  mic::LiveStreamSettings live;
  live.remote_input_period_s = 60.0;  // minute means beside a 1 s pair: its epochs every 60 s
  EXPECT_EQ(where(live, false), "accepted");
  EXPECT_NE(where(live, true).find("remote_input_period_s: of 60 s puts the remote onto the epochs every 60 s"),
            std::string::npos)
      << where(live, true);
  live = mic::LiveStreamSettings{};
  live.input_period_s = 0.1;
  live.test_input_period_s = 1.0;
  live.decimation.sigma_s = 0.1;  // a kernel of +-0.4 s cannot filter a 1 s stream
  EXPECT_EQ(where(live, false).rfind("test_input_period_s: of 1 s: the filter's kernel", 0), 0u) << where(live, false);
  live = mic::LiveStreamSettings{};
  live.test_input_period_s = -1.0;
  EXPECT_EQ(where(live, false).rfind("test_input_period_s", 0), 0u);
}

// The period a stream's stamps step by, against the one its parameter gives: a LEMI-025 at 10 Hz
// under the default 1 s is told after 20 steps, whatever its gaps and jumps.
TEST(StreamMonitor, MeasuresTheStreamsPeriodOnItsStamps) {
  mic::StreamMonitor m;
  const double threshold = 60.0;  // s
  double t = 1747180799.7;
  for (int k = 0; k < 19; ++k) m.observe(t += 0.1, 0.0, "f", threshold);
  EXPECT_TRUE(std::isnan(m.measured_period_s()));  // 18 steps: not yet
  EXPECT_EQ(m.period_problem(1.0), "");
  m.observe(t += 0.1, 0.0, "f", threshold);
  m.observe(t += 0.1, 0.0, "f", threshold);
  EXPECT_NEAR(m.measured_period_s(), 0.1, 1e-6);  // stamps of 1.7e9 s carry 2.4e-7 s
  EXPECT_EQ(m.period_problem(1.0), "stamps step by 0.1 s, not 1 s");
  EXPECT_EQ(m.period_problem(0.1), "");
  EXPECT_EQ(m.period_problem(0.095), "");  // within 10 %
  // Gaps of a few samples, a jump of an hour and a stray stamp leave the median where it is.
  for (int k = 0; k < 300; ++k) m.observe(t += (k % 10 == 9 ? 0.5 : 0.1), 0.0, "f", threshold);
  m.observe(t += 3600.0, 0.0, "f", threshold);
  m.observe(0.0, 0.0, "f", threshold);
  for (int k = 0; k < 5; ++k) m.observe(t += 0.1, 0.0, "f", threshold);
  EXPECT_NEAR(m.measured_period_s(), 0.1, 1e-6);  // stamps of 1.7e9 s carry 2.4e-7 s
  // A 1 s stream where 0.1 s is given.
  mic::StreamMonitor slow;
  for (int k = 0; k < 40; ++k) slow.observe(1747180800.0 + k, 0.0, "f", threshold);
  EXPECT_EQ(slow.period_problem(0.1), "stamps step by 1 s, not 0.1 s");
}

// Where in each period a stream's stamps fall: 1 s stamps 0.3 s after the seconds against a
// reference on them (what keeps them from pairing by stamp), a stray stamp left out.
TEST(StreamMonitor, MeasuresWhereInEachPeriodTheStampsFall) {
  mic::StreamMonitor test, reference;
  const double threshold = 60.0, t0 = 1747180800.0;  // s
  for (int k = 0; k < 19; ++k) test.observe(t0 + k + 0.3, 0.0, "f", threshold);
  EXPECT_TRUE(std::isnan(test.stamp_phase_s(1.0)));  // 19 stamps: not yet
  test.observe(t0 + 19.3, 0.0, "f", threshold);
  test.observe(0.0, 0.0, "f", threshold);  // a stray stamp
  for (int k = 20; k < 200; ++k) test.observe(t0 + k + 0.3, 0.0, "f", threshold);
  for (int k = 0; k < 200; ++k) reference.observe(t0 + k, 0.0, "f", threshold);
  EXPECT_NEAR(test.stamp_phase_s(1.0), 0.3, 1e-6);
  EXPECT_NEAR(mic::phase_offset_s(test.stamp_phase_s(1.0), reference.stamp_phase_s(1.0), 1.0), 0.3, 1e-6);
  EXPECT_NEAR(mic::phase_offset_s(reference.stamp_phase_s(1.0), test.stamp_phase_s(1.0), 1.0), -0.3, 1e-6);
  // 0.9 s after is 0.1 s before.
  mic::StreamMonitor late;
  for (int k = 0; k < 40; ++k) late.observe(t0 + k + 0.9, 0.0, "f", threshold);
  EXPECT_NEAR(mic::phase_offset_s(late.stamp_phase_s(1.0), reference.stamp_phase_s(1.0), 1.0), -0.1, 1e-6);
}
