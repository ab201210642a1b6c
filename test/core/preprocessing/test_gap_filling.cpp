// regularize_and_fill: exact for linear signals, keeps T = R n, lists long gaps, masks both
// instruments, trims NaN ends, snaps jittered stamps and rejects off-grid ones.
#include "magnetometer_insitu_calibration/preprocessing/gap_filling.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "test_constants.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

namespace mic = magnetometer_insitu_calibration;

namespace {

constexpr double kGapStart = 1747180800.0;  // 2025-05-14T00:00:00Z
using magnetometer_insitu_calibration::test::kPi;
const double kNaN = std::nan("");

/// Reference: a linear function of time per column; test = reference * n + offset drift
/// (also linear in time), nT.
Eigen::RowVector3d linear_reference(double t) {
  const double u = t - kGapStart;
  return Eigen::RowVector3d(20000.0 + 0.013 * u, -300.0 - 0.007 * u, 45000.0 + 0.002 * u);
}

Eigen::Matrix3d calibration_n() {
  Eigen::Matrix3d n;
  n << 1.001, 0.002, -0.001, -0.0015, 0.999, 0.003, 0.0005, -0.002, 1.0004;
  return n;
}

/// Paired record on a 1 s grid with samples `skip` removed.
mic::PairedRecord make_paired(int count, const std::set<int>& skip, bool linear) {
  mic::PairedRecord p;
  std::vector<Eigen::RowVector3d> r, t;
  for (int k = 0; k < count; ++k) {
    if (skip.count(k)) continue;
    const double time = kGapStart + k;
    Eigen::RowVector3d ref = linear_reference(time);
    if (!linear) {
      ref += Eigen::RowVector3d(30 * std::sin(2 * kPi * k / 600.0), 20 * std::cos(2 * kPi * k / 97.0),
                                10 * std::sin(2 * kPi * k / 1800.0 + 1));
    }
    p.time_s.push_back(time);
    r.push_back(ref);
    t.push_back(ref * calibration_n());
  }
  p.reference_nT.resize(static_cast<Eigen::Index>(r.size()), 3);
  p.test_nT.resize(static_cast<Eigen::Index>(r.size()), 3);
  for (std::size_t i = 0; i < r.size(); ++i) {
    p.reference_nT.row(static_cast<Eigen::Index>(i)) = r[i];
    p.test_nT.row(static_cast<Eigen::Index>(i)) = t[i];
  }
  return p;
}

Eigen::Index row_at(const mic::PairedRecord& p, double time) {
  for (std::size_t i = 0; i < p.time_s.size(); ++i) {
    if (p.time_s[i] == time) return static_cast<Eigen::Index>(i);
  }
  return -1;
}

}  // namespace

TEST(GapFilling, LinearSignalIsReproducedExactlyAcrossGaps) {
  std::set<int> skip{5, 6, 7, 100};
  for (int k = 200; k < 290; ++k) skip.insert(k);  // 90 s gap: longer than a max_fill_s of 60
  mic::PairedRecord p = make_paired(400, skip, true);
  p.reference_nT(row_at(p, kGapStart + 50), 1) = kNaN;  // NaN in one reference component
  p.test_nT(row_at(p, kGapStart + 60), 2) = kNaN;       // NaN in one test component
  const mic::GapReport report = mic::regularize_and_fill(p, 1.0, mic::GapSettings{60.0});

  ASSERT_EQ(p.size(), 400u);
  ASSERT_EQ(report.filled.size(), 400u);
  EXPECT_EQ(report.inserted_epochs, skip.size());
  EXPECT_EQ(report.masked_samples, 2u);
  EXPECT_EQ(report.filled_samples, skip.size() + 2);
  ASSERT_EQ(report.long_gaps.size(), 1u);
  EXPECT_EQ(report.long_gaps[0], std::make_pair(std::size_t{200}, std::size_t{289}));
  const Eigen::Matrix3d n = calibration_n();
  double worst_ref = 0, worst_relation = 0;
  for (std::size_t k = 0; k < 400; ++k) {
    const auto r = static_cast<Eigen::Index>(k);
    EXPECT_EQ(p.time_s[k], kGapStart + static_cast<double>(k));
    const bool should_fill = skip.count(static_cast<int>(k)) || k == 50 || k == 60;
    EXPECT_EQ(report.filled[k], should_fill ? 1 : 0) << k;
    worst_ref = std::max(worst_ref, (p.reference_nT.row(r) - linear_reference(p.time_s[k])).cwiseAbs().maxCoeff());
    worst_relation = std::max(worst_relation, (p.test_nT.row(r) - p.reference_nT.row(r) * n).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst_ref, 1e-9);       // linear in time: interpolation is exact
  EXPECT_LT(worst_relation, 1e-9);  // T = R n everywhere
}

TEST(GapFilling, NaNInOneInstrumentMasksBothAndKeepsTheLinearRelation) {
  // Non-linear signals: interpolated values differ from the truth, but because both records
  // are interpolated at the same epochs T = R n still holds exactly.
  mic::PairedRecord p = make_paired(300, {}, false);
  const double test_value_before = p.test_nT(150, 0);
  for (Eigen::Index k = 140; k < 160; ++k) p.reference_nT(k, 0) = kNaN;  // reference X only
  const mic::GapReport report = mic::regularize_and_fill(p, 1.0, mic::GapSettings{});
  EXPECT_EQ(report.filled_samples, 20u);
  EXPECT_TRUE(report.long_gaps.empty());
  EXPECT_EQ(report.masked_samples, 20u);
  EXPECT_EQ(report.filled[150], 1);
  // The test sample at the masked epoch was replaced by the straight line through epochs 139
  // and 160 (its own value is not kept).
  const Eigen::RowVector3d expected_test = p.test_nT.row(139) + (11.0 / 21.0) * (p.test_nT.row(160) - p.test_nT.row(139));
  EXPECT_LT((p.test_nT.row(150) - expected_test).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_GT(std::abs(p.test_nT(150, 0) - test_value_before), 1e-3);
  EXPECT_LT((p.test_nT - p.reference_nT * calibration_n()).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(GapFilling, GapExactlyAtMaxFillIsNotLong) {
  std::set<int> sixty, sixty_one;
  for (int k = 100; k < 160; ++k) sixty.insert(k);
  for (int k = 100; k < 161; ++k) sixty_one.insert(k);
  mic::PairedRecord a = make_paired(300, sixty, true), b = make_paired(300, sixty_one, true);
  EXPECT_TRUE(mic::regularize_and_fill(a, 1.0, mic::GapSettings{60.0}).long_gaps.empty());
  const auto report = mic::regularize_and_fill(b, 1.0, mic::GapSettings{60.0});
  ASSERT_EQ(report.long_gaps.size(), 1u);
  EXPECT_EQ(report.long_gaps[0], std::make_pair(std::size_t{100}, std::size_t{160}));
}

TEST(GapFilling, LeadingAndTrailingNaNRowsAreTrimmed) {
  mic::PairedRecord p = make_paired(100, {}, true);
  for (Eigen::Index k = 0; k < 3; ++k) p.test_nT(k, 1) = kNaN;
  for (Eigen::Index k = 95; k < 100; ++k) p.reference_nT(k, 2) = kNaN;
  const mic::GapReport report = mic::regularize_and_fill(p, 1.0, mic::GapSettings{});
  EXPECT_EQ(report.trimmed_leading, 3u);
  EXPECT_EQ(report.trimmed_trailing, 5u);
  ASSERT_EQ(p.size(), 92u);
  EXPECT_EQ(p.time_s.front(), kGapStart + 3);
  EXPECT_EQ(p.time_s.back(), kGapStart + 94);
  EXPECT_EQ(report.filled_samples, 0u);
  EXPECT_TRUE(p.reference_nT.allFinite() && p.test_nT.allFinite());
}

TEST(GapFilling, JitteredStampsSnapToTheGridAndOffGridStampsThrow) {
  // 10 Hz with +-20 ms jitter (less than dt/4 = 25 ms) and a jittered first stamp.
  mic::PairedRecord p = make_paired(50, {}, true);
  for (std::size_t k = 0; k < p.size(); ++k) p.time_s[k] = kGapStart + 0.1 * static_cast<double>(k) + 0.02 * std::sin(1.3 * k + 1);
  p.time_s[0] = kGapStart - 0.02;
  const std::vector<double> stamps = p.time_s;
  const mic::GapReport report = mic::regularize_and_fill(p, 0.1, mic::GapSettings{});
  ASSERT_EQ(p.size(), 50u);
  EXPECT_EQ(report.inserted_epochs, 0u);
  // Grid phase = median offset of the stamps from the nominal epochs; epochs exactly regular.
  std::vector<double> offsets;
  for (std::size_t k = 0; k < stamps.size(); ++k) offsets.push_back(stamps[k] - (kGapStart + 0.1 * static_cast<double>(k)));
  std::nth_element(offsets.begin(), offsets.begin() + 25, offsets.end());
  const double phase = offsets[25];
  EXPECT_GT(std::abs(phase), 1e-3);  // the jitter pattern really has a non-zero median
  for (std::size_t k = 0; k < p.size(); ++k) {
    EXPECT_NEAR(p.time_s[k], kGapStart + phase + 0.1 * static_cast<double>(k), 1e-6);
  }

  mic::PairedRecord q = make_paired(50, {}, true);
  for (std::size_t k = 0; k < q.size(); ++k) q.time_s[k] = kGapStart + 0.1 * static_cast<double>(k);
  q.time_s[20] += 0.04;  // 40 ms off a 100 ms grid
  try {
    mic::regularize_and_fill(q, 0.1, mic::GapSettings{});
    FAIL() << "no exception";
  } catch (const mic::InputError& e) {
    EXPECT_EQ(e.where(), "--reference/--test");
    EXPECT_NE(e.problem().find("paired sample 20"), std::string::npos) << e.what();
  }
}

TEST(GapFilling, RejectsImpossibleInput) {
  mic::PairedRecord p = make_paired(10, {}, true);
  EXPECT_THROW(mic::regularize_and_fill(p, 0.0, mic::GapSettings{}), mic::InputError);
  EXPECT_THROW(mic::regularize_and_fill(p, 1.0, mic::GapSettings{-1.0}), mic::InputError);
  p.reference_nT.col(0).setConstant(kNaN);
  EXPECT_THROW(mic::regularize_and_fill(p, 1.0, mic::GapSettings{}), mic::InputError);
}
