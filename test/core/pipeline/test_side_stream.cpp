// A side stream (a remote observatory, a third instrument) on the estimation epochs on its own
// (pipeline/side_stream.hpp): at its stamps on the reference's epochs, or through the pair's
// Gaussian FIR; the reference's gaps are its gaps; and, on records whose stamps the reference
// shares, exactly the values the side's pairing with the reference as a test gave it.
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/pipeline/side_stream.hpp"
#include "magnetometer_insitu_calibration/preprocessing/despike.hpp"
#include "magnetometer_insitu_calibration/preprocessing/gaussian_decimation.hpp"
#include "magnetometer_insitu_calibration/simulation/remote_observatory.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include "ten_hz_station.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <string>

namespace mic = magnetometer_insitu_calibration;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kT0 = 1747180800.0;  // UNIX s, a whole second

Eigen::Vector3d row(const mic::VectorRecord& r, std::size_t i) {
  return r.values_nT.row(static_cast<Eigen::Index>(i)).transpose();
}

/// The records through a SideStream, whole (the reference first, as prepare_sides feeds them).
mic::SideStream through(const mic::SideStreamSettings& settings, const mic::VectorRecord& reference,
                        const mic::VectorRecord& side) {
  mic::SideStream stream(settings);
  for (std::size_t i = 0; i < reference.size(); ++i) stream.push_reference(reference.time_s[i], row(reference, i));
  for (std::size_t i = 0; i < side.size(); ++i) stream.push(side.time_s[i], row(side, i));
  stream.finish();
  return stream;
}

/// Equal doubles, or NaN in both.
bool same(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }

/// Values by epoch index (time / period rounded), NaN rows included.
std::map<long long, Eigen::Vector3d> by_epoch(const std::vector<double>& time_s, const mic::Readings& values,
                                              double period_s) {
  std::map<long long, Eigen::Vector3d> out;
  for (std::size_t i = 0; i < time_s.size(); ++i) {
    out[std::llround(time_s[i] / period_s)] = values.row(static_cast<Eigen::Index>(i)).transpose();
  }
  return out;
}

/// Every epoch where either has a finite value holds the same three doubles in both (NaN or
/// absent alike elsewhere); the count of epochs compared.
std::size_t expect_same_epochs(const std::map<long long, Eigen::Vector3d>& a, const std::map<long long, Eigen::Vector3d>& b) {
  std::size_t finite = 0;
  const auto check = [&](const std::map<long long, Eigen::Vector3d>& one, const std::map<long long, Eigen::Vector3d>& other) {
    for (const auto& [epoch, value] : one) {
      if (!value.allFinite()) continue;
      const auto it = other.find(epoch);
      ASSERT_NE(it, other.end()) << "epoch " << epoch;
      for (int c = 0; c < 3; ++c) ASSERT_TRUE(same(value(c), it->second(c))) << "epoch " << epoch << " axis " << c;
      ++finite;
    }
  };
  check(a, b);
  check(b, a);
  return finite / 2;
}

}  // namespace

// One rate and phase: each side sample on the reference's epoch within the pairing tolerance,
// NaN where the reference's value is NaN, nothing where the reference has no sample or lies
// further off.
TEST(SideStream, AtItsStampsTakesTheReferencesEpochsAndItsGaps) {
  mic::VectorRecord reference, side;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  reference.values_nT = side.values_nT = mic::Readings::Constant(10, 3, 1.0);
  for (int k = 0; k < 10; ++k) {
    reference.time_s.push_back(kT0 + k);
    side.time_s.push_back(kT0 + k + (k == 8 ? 0.05 : 0.004));  // 8: 50 ms off, beyond 10 ms
    side.values_nT.row(k).setConstant(10.0 * k);
  }
  reference.values_nT.row(3).setConstant(nan);  // a spike taken out of the reference
  reference.time_s[6] = kT0 + 6.5;              // no reference sample at 6
  side.values_nT(5, 1) = nan;                   // the side's own gap
  mic::SideStreamSettings settings;
  settings.despike = false;
  const mic::SideStream s = through(settings, reference, side);
  EXPECT_EQ(s.alignment(), mic::EpochAlignment::kPairedStamps);
  EXPECT_FALSE(s.filter().has_value());
  EXPECT_EQ(s.period_s(), 1.0);
  const mic::VectorRecord all = s.on_epochs(-kInf, kInf);
  const std::vector<double> expected_times = {kT0, kT0 + 1, kT0 + 2, kT0 + 3, kT0 + 4, kT0 + 5, kT0 + 7, kT0 + 9};
  EXPECT_EQ(all.time_s, expected_times);  // the reference's stamps
  ASSERT_EQ(all.values_nT.rows(), 8);
  EXPECT_TRUE(all.values_nT.row(3).array().isNaN().all());  // the reference's NaN
  EXPECT_TRUE(all.values_nT.row(5).array().isNaN().all());  // its own, in one component
  EXPECT_EQ(all.values_nT(4, 0), 40.0);
  EXPECT_EQ(all.values_nT(6, 2), 70.0);
  const mic::VectorRecord some = s.on_epochs(kT0 + 1.5, kT0 + 4.5);
  EXPECT_EQ(some.time_s, (std::vector<double>{kT0 + 2, kT0 + 3, kT0 + 4}));
  EXPECT_EQ(s.reached_s(), kT0 + 9);  // the reference's last; the side's is 4 ms later
}

TEST(SideStream, ReachedStaysWhereItWasWhenItsEpochsAreForgotten) {
  // A remote that stopped: the windows still waiting start after its last sample, so its epochs
  // are forgotten (drop_before); it has still reached that sample, and a stamp at or before it
  // stays refused.
  mic::SideStreamSettings settings;
  settings.despike = false;
  mic::SideStream s(settings);
  for (int k = 0; k < 100; ++k) s.push_reference(kT0 + k, Eigen::Vector3d::Constant(1.0));
  for (int k = 0; k < 40; ++k) s.push(kT0 + k, Eigen::Vector3d::Constant(2.0));
  EXPECT_EQ(s.reached_s(), kT0 + 39);
  s.drop_before(kT0 + 60);
  EXPECT_EQ(s.on_epochs(-kInf, kInf).size(), 0u);
  EXPECT_EQ(s.reached_s(), kT0 + 39);
  EXPECT_EQ(s.newest_s(), kT0 + 99);
  s.push(kT0 + 39, Eigen::Vector3d::Constant(2.0));
  EXPECT_EQ(s.rejected(), 1u);
  EXPECT_EQ(s.reached_s(), kT0 + 39);
  s.push(kT0 + 70, Eigen::Vector3d::Constant(2.0));  // it returns: the epochs it reaches again
  EXPECT_EQ(s.reached_s(), kT0 + 70);
  EXPECT_EQ(s.on_epochs(kT0 + 60, kInf).size(), 1u);
  s.reset();
  EXPECT_EQ(s.reached_s(), -kInf);
}

// Faster than the estimation period (10 Hz, 1 s epochs): the side through its own Gaussian FIR,
// exactly decimate() of its despiked record alone, missing where the reference's own filtered
// value is; the pair's paired-then-decimated way is each filtered for a stream without partner.
TEST(SideStream, FilteredItIsTheBatchFilterOfItsRecordAloneOnTheReferencesEpochs) {
  mic::SimulationSettings s = mic::test::ten_hz_station(61, 2.0);
  s.keep_clean_field = true;
  s.spikes_per_day = 300;
  s.spike_instrument = mic::SimulatedInstrument::kReference;
  s.gap_count = 2;
  s.gap_length_s = 30.0;
  s.gap_instrument = mic::SimulatedInstrument::kReference;
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::RemoteObservatorySettings r;
  r.gap_count = 1;
  r.gap_length_s = 20.0;
  mic::VectorRecord remote = mic::simulate_remote_observatory(s, pair, r);
  for (Eigen::Index i = 500; i < remote.values_nT.rows(); i += 4001) remote.values_nT(i, 2) += 40.0;
  mic::VectorRecord despiked_reference = pair.reference, despiked_remote = remote;
  mic::despike(despiked_reference.values_nT, mic::DespikeSettings{});  // as the pair takes it
  mic::despike(despiked_remote.values_nT, mic::DespikeSettings{});
  mic::SideStreamSettings settings;
  settings.reference_period_s = settings.side_period_s = 0.1;
  const mic::SideStream stream = through(settings, despiked_reference, remote);
  EXPECT_EQ(settings.plan().alignment, mic::EpochAlignment::kPairedThenDecimated);
  EXPECT_EQ(stream.alignment(), mic::EpochAlignment::kEachFiltered);
  ASSERT_TRUE(stream.filter().has_value());
  EXPECT_GT(stream.spikes(), 5u);

  const mic::VectorRecord filtered_reference = mic::decimate(despiked_reference, *stream.filter());
  mic::VectorRecord expected = mic::decimate(despiked_remote, *stream.filter());
  const std::map<long long, Eigen::Vector3d> reference_epochs =
      by_epoch(filtered_reference.time_s, filtered_reference.values_nT, 1.0);
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const auto it = reference_epochs.find(std::llround(expected.time_s[i]));
    if (it == reference_epochs.end() || !it->second.allFinite()) {
      expected.values_nT.row(static_cast<Eigen::Index>(i)).setConstant(std::numeric_limits<double>::quiet_NaN());
    }
  }
  const mic::VectorRecord got = stream.on_epochs(-kInf, kInf);
  EXPECT_GT(expect_same_epochs(by_epoch(got.time_s, got.values_nT, 1.0), by_epoch(expected.time_s, expected.values_nT, 1.0)),
            6000u);
  std::size_t masked = 0;  // the reference's gaps and spikes reach the side
  for (Eigen::Index i = 0; i < got.values_nT.rows(); ++i) masked += got.values_nT.row(i).hasNaN() ? 1 : 0;
  EXPECT_GT(masked, 60u);
}

// On records whose stamps the reference shares (1 s, and 10 Hz decimated to 1 s), with spikes
// and gaps in the reference and in the side: the side's samples on the epochs are, value for
// value, the test half of prepare_pair(reference, side), the pairing a side record went through
// as a test.
TEST(SideStream, GivesTheValuesOfThePairingWithTheReferenceAsATest) {
  for (const double period : {1.0, 0.1}) {
    SCOPED_TRACE("period " + std::to_string(period));
    mic::SimulationSettings s = period == 1.0 ? mic::SimulationSettings{} : mic::test::ten_hz_station(67, 2.0);
    s.seed = 67;
    s.duration_s = 2.0 * 3600.0;
    s.keep_clean_field = true;
    s.spikes_per_day = 400;
    s.spike_instrument = mic::SimulatedInstrument::kEither;
    s.gap_count = 3;
    s.gap_length_s = 40.0;
    const mic::SimulatedPair pair = mic::simulate_pair(s);
    mic::RemoteObservatorySettings r;
    r.gap_count = 2;
    r.gap_length_s = 30.0;
    const mic::VectorRecord remote = mic::simulate_remote_observatory(s, pair, r);
    mic::SideStreamSettings settings;
    settings.reference_period_s = settings.side_period_s = period;
    mic::VectorRecord despiked_reference = pair.reference;
    mic::despike(despiked_reference.values_nT, mic::DespikeSettings{});
    const mic::SideStream stream = through(settings, despiked_reference, remote);
    const mic::VectorRecord got = stream.on_epochs(-kInf, kInf);
    const mic::PreparedPair paired = mic::prepare_pair(pair.reference, remote, mic::PreprocessSettings{});
    const std::size_t compared = expect_same_epochs(by_epoch(got.time_s, got.values_nT, 1.0),
                                                    by_epoch(paired.paired.time_s, paired.paired.test_nT, 1.0));
    EXPECT_GT(compared, 5000u);
  }
}

// Pushed as the samples arrive, interleaved, with what no window needs dropped on the way: the
// same samples on the epochs as the whole records give.
TEST(SideStream, PushedAsItArrivesItGivesTheWholeRecordsEpochs) {
  mic::SimulationSettings s = mic::test::ten_hz_station(71, 1.0);
  s.keep_clean_field = true;
  s.spikes_per_day = 500;
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  const mic::VectorRecord remote = mic::test::every_tenth(mic::simulate_remote_observatory(s, pair, {}), 3);
  mic::SideStreamSettings settings;
  settings.reference_period_s = 0.1;
  settings.side_period_s = 1.0;
  const mic::SideStream whole = through(settings, pair.reference, remote);
  mic::SideStream live(settings);
  std::size_t next = 0;
  const double from = kT0 + 1200.0, to = kT0 + 1800.0;
  for (std::size_t i = 0; i < pair.reference.size(); ++i) {
    live.push_reference(pair.reference.time_s[i], row(pair.reference, i));
    while (next < remote.size() && remote.time_s[next] <= pair.reference.time_s[i]) {
      live.push(remote.time_s[next], row(remote, next));
      ++next;
    }
    if (live.reached_s() < from) live.drop_before(live.reached_s() - 10.0);  // only what [from, to) needs
  }
  EXPECT_EQ(live.received(), remote.size());
  EXPECT_EQ(live.alignment(), mic::EpochAlignment::kEachFiltered);
  const mic::VectorRecord a = live.on_epochs(from, to), b = whole.on_epochs(from, to);
  EXPECT_EQ(a.time_s, b.time_s);
  ASSERT_EQ(a.values_nT.rows(), 600);
  for (Eigen::Index i = 0; i < a.values_nT.rows(); ++i)
    for (int c = 0; c < 3; ++c) EXPECT_TRUE(same(a.values_nT(i, c), b.values_nT(i, c))) << i;
}
