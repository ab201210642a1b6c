// align_by_time: counts and values against records built with known pairings.
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/preprocessing/time_alignment.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace mic = magnetometer_insitu_calibration;

namespace {

constexpr double kAlignmentStart = 1747180800.0;  // 2025-05-14T00:00:00Z
constexpr double kAlignmentPeriod = 0.1;          // 10 Hz

/// Value of sample k: (k, 2k, 3k) nT for the reference, (k + 0.5, ...) for the test, so each
/// output row tells which input sample it came from.
mic::VectorRecord make_record(const std::vector<double>& times, const std::vector<double>& ids,
                              const std::string& source) {
  mic::VectorRecord record;
  record.time_s = times;
  record.source = source;
  record.values_nT.resize(static_cast<Eigen::Index>(times.size()), 3);
  for (std::size_t k = 0; k < times.size(); ++k) {
    record.values_nT.row(static_cast<Eigen::Index>(k)) << ids[k], 2 * ids[k], 3 * ids[k];
  }
  return record;
}

}  // namespace

TEST(TimeAlignment, JitterWithinAndBeyondToleranceGivesExactCounts) {
  // Reference: 1000 samples at exact 10 Hz epochs. Test: same epochs with a jitter pattern;
  // |jitter| <= 9 ms pairs, 15 ms does not; every 50th test sample is missing; 20 extra test
  // samples lie after the reference ends.
  const int n = 1000;
  std::vector<double> ref_t, ref_id, test_t, test_id;
  int expected_pairs = 0, beyond = 0, missing = 0;
  for (int k = 0; k < n; ++k) {
    ref_t.push_back(kAlignmentStart + k * kAlignmentPeriod);
    ref_id.push_back(k);
    if (k % 50 == 7) {
      ++missing;
      continue;
    }
    double jitter = 0.009 * std::sin(0.37 * k);  // within +-9 ms
    if (k % 97 == 3) {
      jitter = (k % 2 ? 0.015 : -0.015);  // beyond the 10 ms tolerance
      ++beyond;
    } else {
      ++expected_pairs;
    }
    test_t.push_back(kAlignmentStart + k * kAlignmentPeriod + jitter);
    test_id.push_back(k + 0.5);
  }
  for (int k = 0; k < 20; ++k) {
    test_t.push_back(kAlignmentStart + (n + k) * kAlignmentPeriod);
    test_id.push_back(n + k + 0.5);
  }
  const auto paired = mic::align_by_time(make_record(ref_t, ref_id, "ref.sec"),
                                         make_record(test_t, test_id, "test.sec"), 0.010);
  ASSERT_EQ(paired.size(), static_cast<std::size_t>(expected_pairs));
  EXPECT_EQ(paired.unpaired_reference, static_cast<std::size_t>(beyond + missing));
  EXPECT_EQ(paired.unpaired_test, static_cast<std::size_t>(beyond + 20));
  EXPECT_EQ(paired.duplicates, 0u);
  EXPECT_GT(beyond, 5);
  for (std::size_t k = 0; k < paired.size(); ++k) {
    const double id = paired.reference_nT(static_cast<Eigen::Index>(k), 0);
    // Output time is the reference stamp; the test row is the same epoch's sample.
    EXPECT_EQ(paired.time_s[k], kAlignmentStart + id * kAlignmentPeriod);
    EXPECT_EQ(paired.test_nT(static_cast<Eigen::Index>(k), 0), id + 0.5);
    EXPECT_EQ(paired.test_nT(static_cast<Eigen::Index>(k), 2), 3 * (id + 0.5));
    if (k > 0) {
      EXPECT_GT(paired.time_s[k], paired.time_s[k - 1]);
    }
  }
}

TEST(TimeAlignment, PairsTheNearestSampleAndToleranceIsInclusive) {
  // Two test samples near reference epoch 1, both within tolerance: the nearer one (+3 ms)
  // pairs, the other (-5 ms) is left over. Epoch 2 pairs at exactly the tolerance (2^-7 s,
  // exactly representable next to a UNIX time, so the test does not hang on rounding).
  const double tolerance = 0.0078125;
  const std::vector<double> ref_t{kAlignmentStart, kAlignmentStart + 1.0, kAlignmentStart + 2.0};
  const std::vector<double> test_t{kAlignmentStart + 0.5, kAlignmentStart + 0.995, kAlignmentStart + 1.003, kAlignmentStart + 2.0 + tolerance};
  const auto paired = mic::align_by_time(make_record(ref_t, {0, 1, 2}, "r"),
                                         make_record(test_t, {10, 11, 12, 13}, "t"), tolerance);
  ASSERT_EQ(paired.size(), 2u);
  EXPECT_EQ(paired.test_nT(0, 0), 12);
  EXPECT_EQ(paired.test_nT(1, 0), 13);
  EXPECT_EQ(paired.time_s[1], kAlignmentStart + 2.0);
  EXPECT_EQ(paired.unpaired_reference, 1u);
  EXPECT_EQ(paired.unpaired_test, 2u);
}

TEST(TimeAlignment, RepeatedStampsAreCountedAsDuplicatesAndDropped) {
  const std::vector<double> ref_t{kAlignmentStart, kAlignmentStart + 1.0, kAlignmentStart + 1.0, kAlignmentStart + 2.0};
  const std::vector<double> test_t{kAlignmentStart, kAlignmentStart, kAlignmentStart + 1.0, kAlignmentStart + 2.0};
  const auto paired = mic::align_by_time(make_record(ref_t, {0, 1, 99, 2}, "r"),
                                         make_record(test_t, {10, 98, 11, 12}, "t"));
  ASSERT_EQ(paired.size(), 3u);
  EXPECT_EQ(paired.duplicates, 2u);
  EXPECT_EQ(paired.reference_nT(1, 0), 1);  // the first of the repeated samples is kept
  EXPECT_EQ(paired.test_nT(0, 0), 10);
  EXPECT_EQ(paired.unpaired_reference, 0u);
  EXPECT_EQ(paired.unpaired_test, 0u);
}

TEST(TimeAlignment, BackwardsStampThrowsNamingSourceAndIndex) {
  const std::vector<double> bad{kAlignmentStart, kAlignmentStart + 1.0, kAlignmentStart + 0.5};
  const std::vector<double> good{kAlignmentStart, kAlignmentStart + 1.0, kAlignmentStart + 2.0};
  try {
    mic::align_by_time(make_record(good, {0, 1, 2}, "ref.sec"), make_record(bad, {0, 1, 2}, "test.sec"));
    FAIL() << "no exception";
  } catch (const mic::InputError& e) {
    EXPECT_EQ(e.where(), "test.sec");
    EXPECT_NE(e.problem().find("sample 2"), std::string::npos) << e.what();
  }
}

TEST(TimeAlignment, DisjointRecordsThrow) {
  const std::vector<double> a{kAlignmentStart, kAlignmentStart + 1.0};
  const std::vector<double> b{kAlignmentStart + 10.0, kAlignmentStart + 11.0};
  try {
    mic::align_by_time(make_record(a, {0, 1}, "r"), make_record(b, {0, 1}, "t"));
    FAIL() << "no exception";
  } catch (const mic::InputError& e) {
    EXPECT_EQ(e.where(), "--reference/--test");
    EXPECT_EQ(e.problem(), "records do not overlap in time: reference r spans 2025-05-14T00:00:00.000Z to "
                           "2025-05-14T00:00:01.000Z, test t spans 2025-05-14T00:00:10.000Z to 2025-05-14T00:00:11.000Z");
  }
}

// Spans that overlap with stamps that never come within the tolerance: said so, not "no overlap".
TEST(TimeAlignment, InterleavedStampsBeyondTheToleranceAreNamed) {
  const std::vector<double> a{kAlignmentStart, kAlignmentStart + 1.0};
  const std::vector<double> b{kAlignmentStart + 0.5, kAlignmentStart + 1.5};
  try {
    mic::align_by_time(make_record(a, {0, 1}, "r.sec"), make_record(b, {0, 1}, "t.sec"), 0.01);
    FAIL() << "no exception";
  } catch (const mic::InputError& e) {
    EXPECT_EQ(e.problem(), "no reference and test stamps within the pairing tolerance of 0.01 s of each other: "
                           "reference r.sec spans 2025-05-14T00:00:00.000Z to 2025-05-14T00:00:01.000Z, test t.sec "
                           "spans 2025-05-14T00:00:00.500Z to 2025-05-14T00:00:01.500Z");
  }
}

TEST(TimeAlignment, NaNValuesPassThrough) {
  auto ref = make_record({kAlignmentStart, kAlignmentStart + 1.0}, {0, 1}, "r");
  auto test = make_record({kAlignmentStart + 0.001, kAlignmentStart + 1.001}, {5, 6}, "t");
  ref.values_nT(1, 1) = std::nan("");
  const auto paired = mic::align_by_time(ref, test);
  ASSERT_EQ(paired.size(), 2u);
  EXPECT_TRUE(std::isnan(paired.reference_nT(1, 1)));
  EXPECT_EQ(paired.test_nT(1, 1), 12);
}
