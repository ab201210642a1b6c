// StreamPairer: same pairs as align_by_time on interleaved live streams, bounded memory with a
// silent stream, late / duplicate / invalid samples counted.
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/preprocessing/stream_pairing.hpp"
#include "magnetometer_insitu_calibration/preprocessing/time_alignment.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <deque>

namespace mic = magnetometer_insitu_calibration;

namespace {

constexpr double kStart = 1747180800.0;
constexpr double kPeriod = 0.1;

Eigen::Vector3d value_of(double id) { return Eigen::Vector3d(id, 2 * id, 3 * id); }

/// Test stamp of epoch k: jitter within +-9 ms, every 97th beyond the 10 ms tolerance; every
/// 50th test sample missing (returns NaN).
double test_stamp(int k) {
  if (k % 50 == 7) return std::nan("");
  double jitter = 0.009 * std::sin(0.37 * k);
  if (k % 97 == 3) jitter = (k % 2 ? 0.015 : -0.015);
  return kStart + k * kPeriod + jitter;
}

}  // namespace

TEST(StreamPairing, InterleavedStreamsGiveTheSamePairsAsBatchAlignment) {
  const int n = 3000;
  mic::VectorRecord ref, test;
  ref.values_nT.resize(n, 3);
  std::vector<Eigen::Vector3d> test_values;
  for (int k = 0; k < n; ++k) {
    ref.time_s.push_back(kStart + k * kPeriod);
    ref.values_nT.row(k) = value_of(k).transpose();
    const double t = test_stamp(k);
    if (std::isnan(t)) continue;
    test.time_s.push_back(t);
    test_values.push_back(value_of(k + 0.5));
  }
  test.values_nT.resize(static_cast<Eigen::Index>(test_values.size()), 3);
  for (std::size_t j = 0; j < test_values.size(); ++j) test.values_nT.row(static_cast<Eigen::Index>(j)) = test_values[j].transpose();
  const mic::PairedRecord batch = mic::align_by_time(ref, test, 0.010);

  // Live: the test stream arrives 0.35 s (3-4 samples) after the reference stream.
  mic::StreamPairer pairer(0.010, 5.0);
  std::vector<mic::PairedSample> pairs;
  std::size_t j = 0;
  for (int k = 0; k < n; ++k) {
    pairer.push_reference(ref.time_s[static_cast<std::size_t>(k)], ref.values_nT.row(k).transpose());
    while (j < test.size() && test.time_s[j] <= ref.time_s[static_cast<std::size_t>(k)] - 0.35) {
      pairer.push_test(test.time_s[j], test.values_nT.row(static_cast<Eigen::Index>(j)).transpose());
      ++j;
    }
    for (auto& p : pairer.take_pairs()) pairs.push_back(p);
    ASSERT_LT(pairer.pending_reference(), 10u);
    ASSERT_LT(pairer.pending_test(), 10u);
  }
  for (; j < test.size(); ++j) pairer.push_test(test.time_s[j], test.values_nT.row(static_cast<Eigen::Index>(j)).transpose());
  pairer.flush();
  for (auto& p : pairer.take_pairs()) pairs.push_back(p);

  ASSERT_EQ(pairs.size(), batch.size());
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    EXPECT_EQ(pairs[k].time_s, batch.time_s[k]);
    EXPECT_EQ(pairs[k].reference_nT, batch.reference_nT.row(static_cast<Eigen::Index>(k)).transpose());
    EXPECT_EQ(pairs[k].test_nT, batch.test_nT.row(static_cast<Eigen::Index>(k)).transpose());
  }
  const mic::PairingCounters& c = pairer.counters();
  EXPECT_EQ(c.paired, batch.size());
  EXPECT_EQ(c.unpaired_reference, batch.unpaired_reference);
  EXPECT_EQ(c.unpaired_test, batch.unpaired_test);
  EXPECT_GT(c.unpaired_reference, 60u);  // 60 missing + 31 beyond tolerance
  EXPECT_EQ(c.late + c.duplicates + c.invalid, 0u);
  EXPECT_EQ(pairer.pending_reference() + pairer.pending_test(), 0u);
}

TEST(StreamPairing, SilentStreamKeepsMemoryBoundedAndPairingResumes) {
  const double max_wait = 5.0;
  mic::StreamPairer pairer(0.010, max_wait);
  const int silent = 20000;  // 2000 s of reference only
  for (int k = 0; k < silent; ++k) {
    pairer.push_reference(kStart + k * kPeriod, value_of(k));
    ASSERT_LE(pairer.pending_reference(), 51u);  // max_wait_s * 10 Hz + 1
  }
  EXPECT_TRUE(pairer.take_pairs().empty());
  EXPECT_EQ(pairer.counters().unpaired_reference, silent - pairer.pending_reference());
  // The test stream comes back: pairing resumes; the reference samples it missed stay unpaired.
  for (int k = silent; k < silent + 100; ++k) {
    pairer.push_reference(kStart + k * kPeriod, value_of(k));
    pairer.push_test(kStart + k * kPeriod + 0.002, value_of(k + 0.5));
  }
  pairer.flush();
  const auto pairs = pairer.take_pairs();
  ASSERT_EQ(pairs.size(), 100u);
  EXPECT_EQ(pairs.front().time_s, kStart + silent * kPeriod);
  EXPECT_EQ(pairer.counters().unpaired_reference, static_cast<std::size_t>(silent));
  EXPECT_EQ(pairer.counters().unpaired_test, 0u);
}

TEST(StreamPairing, WaitsForTheNextSampleOnlyWhenItCouldBeCloser) {
  mic::StreamPairer pairer(0.010, 5.0);
  // Test 3 ms before the reference: a test sample in (0.997, 1.003) could still be closer to
  // the reference, so the pair waits.
  pairer.push_reference(kStart + 1.000, value_of(1));
  pairer.push_test(kStart + 0.997, value_of(1.5));
  EXPECT_TRUE(pairer.take_pairs().empty());
  // It comes (2 ms after): the first test sample is dropped. Now the test sample is later than
  // the reference, so a reference in (1.000, 1.004) could be closer to it: wait again.
  pairer.push_test(kStart + 1.002, value_of(2.5));
  EXPECT_TRUE(pairer.take_pairs().empty());
  EXPECT_EQ(pairer.counters().unpaired_test, 1u);
  // The next reference is farther: the pair is decided.
  pairer.push_reference(kStart + 1.100, value_of(4));
  auto pairs = pairer.take_pairs();
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0].time_s, kStart + 1.000);
  EXPECT_EQ(pairs[0].test_nT, value_of(2.5));
  // Equal stamps: nothing can be closer, emitted at once.
  pairer.push_test(kStart + 1.100, value_of(4.5));
  pairs = pairer.take_pairs();
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0].time_s, kStart + 1.100);
  EXPECT_EQ(pairs[0].test_nT, value_of(4.5));
  EXPECT_EQ(pairer.pending_reference() + pairer.pending_test(), 0u);
}

TEST(StreamPairing, CountsLateDuplicateAndInvalidSamples) {
  mic::StreamPairer pairer(0.010, 2.0);
  for (int k = 0; k < 100; ++k) {
    pairer.push_reference(kStart + k * kPeriod, value_of(k));
    pairer.push_test(kStart + k * kPeriod, value_of(k + 0.5));
  }
  const std::size_t paired = pairer.take_pairs().size();
  EXPECT_GE(paired, 98u);
  // Late: older than what was already emitted on that stream.
  pairer.push_reference(kStart + 5.05, value_of(-1));
  pairer.push_test(kStart + 0.55, value_of(-1));
  EXPECT_EQ(pairer.counters().late, 2u);
  // Duplicates: the last emitted stamp again, and a pending stamp again.
  pairer.push_reference(kStart + 0.1 * (paired - 1), value_of(-2));
  pairer.push_reference(kStart + 100 * kPeriod, value_of(100));
  pairer.push_reference(kStart + 100 * kPeriod, value_of(-3));
  EXPECT_EQ(pairer.counters().duplicates, 2u);
  pairer.push_test(std::nan(""), value_of(-4));
  EXPECT_EQ(pairer.counters().invalid, 1u);
  // Slightly out of order within a stream (but not late) is accepted in place.
  pairer.push_reference(kStart + 102 * kPeriod, value_of(102));
  pairer.push_reference(kStart + 101 * kPeriod, value_of(101));
  pairer.push_test(kStart + 100 * kPeriod + 0.001, value_of(100.5));
  pairer.push_test(kStart + 101 * kPeriod, value_of(101.5));
  pairer.push_test(kStart + 102 * kPeriod, value_of(102.5));
  pairer.flush();
  const auto pairs = pairer.take_pairs();
  ASSERT_EQ(pairs.size(), 3u);
  EXPECT_EQ(pairs[0].reference_nT, value_of(100));
  EXPECT_EQ(pairs[0].test_nT, value_of(100.5));
  EXPECT_EQ(pairs[1].reference_nT, value_of(101));
  EXPECT_EQ(pairs[1].test_nT, value_of(101.5));
  EXPECT_EQ(pairs[2].test_nT, value_of(102.5));
  for (const auto& p : pairs) EXPECT_GE(p.reference_nT(0), 0.0);  // no rejected sample leaked
  EXPECT_EQ(pairer.counters().paired, paired + pairs.size());
  EXPECT_EQ(pairer.counters().unpaired_reference + pairer.counters().unpaired_test, 0u);
}

TEST(StreamPairing, RecoversFromAStampInTheFuture) {
  mic::StreamPairer pairer(0.010, 5.0);
  std::size_t pairs = 0;
  for (int k = 0; k < 1000; ++k) {
    if (k == 500) pairer.push_reference(kStart + 3.15e7, value_of(-1));  // one year ahead
    pairer.push_reference(kStart + k * kPeriod, value_of(k));
    pairer.push_test(kStart + k * kPeriod + 0.003, value_of(k + 0.5));
    for (const auto& p : pairer.take_pairs()) {
      EXPECT_GE(p.reference_nT(0), 0.0);
      ++pairs;
    }
  }
  pairer.flush();
  pairs += pairer.take_pairs().size();
  EXPECT_EQ(pairer.counters().invalid, 1u);
  // Only the samples pending when the glitch came could be lost; here they all could pair.
  EXPECT_EQ(pairs, 1000u);
  EXPECT_EQ(pairer.counters().unpaired_reference + pairer.counters().unpaired_test, 0u);
}

TEST(StreamPairing, RejectsImpossibleSettings) {
  EXPECT_THROW(mic::StreamPairer(-0.01, 1.0), mic::InputError);
  EXPECT_THROW(mic::StreamPairer(0.01, std::nan("")), mic::InputError);
}
