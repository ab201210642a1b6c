// Self-consistency on the real WIC pair of 2025-05-14 (Conrad Observatory, CC-BY-4.0; see
// data/README.md): LEMI-036 reference, DTU FGE test. No truth is known for real instruments, so
// the checks are the ones an observatory would make: each 6-hour interval agrees with the whole
// day within the two intervals, and swapping the roles gives the inverse calibration.
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

namespace mic = magnetometer_insitu_calibration;

namespace {

struct WicPair {
  mic::VectorRecord reference, test;
};

const WicPair& wic() {
  static const WicPair pair{mic::read_record(mic::test::package_data("wic20250514_lemi036.sec.gz")),
                            mic::read_record(mic::test::package_data("wic20250514_fge.sec.gz"))};
  return pair;
}

Eigen::Matrix<double, 9, 1> values(const mic::CalibrationParameters& p) {
  Eigen::Matrix<double, 9, 1> v;
  v << p.scale_ratio, p.nonorthogonality_deg, p.misalignment_deg;
  return v;
}
Eigen::Matrix<double, 9, 1> half_widths(const mic::CalibrationParameters& p) {
  Eigen::Matrix<double, 9, 1> v;
  v << p.scale_ratio_ci95, p.nonorthogonality_ci95_deg, p.misalignment_ci95_deg;
  return v;
}

}  // namespace

TEST(WicRecords, PairsEverySecondOfTheDay) {
  mic::PreprocessReport report;
  const auto prepared = mic::prepare_pair(wic().reference, wic().test, mic::PreprocessSettings{}, &report);
  EXPECT_EQ(report.paired, 86400u);
  EXPECT_EQ(report.unpaired_reference + report.unpaired_test, 0u);
  EXPECT_EQ(report.filled_samples, 0u);
  EXPECT_FALSE(report.decimated);
  EXPECT_DOUBLE_EQ(prepared.sample_period_s, 1.0);
}

TEST(WicRecords, SixHourIntervalsAgreeWithTheWholeDay) {
  mic::CalibrationSettings settings;
  settings.windows.intervals = 4;
  const auto result = mic::calibrate_records(wic().reference, wic().test, settings);
  ASSERT_EQ(result.windows.size(), 5u);
  const auto& day = result.windows[4].estimate;
  ASSERT_EQ(day.quality, mic::Quality::kOk) << day.quality_text;
  // Real orientation differences between piers of the order of a degree, scale within 1 %.
  EXPECT_LT((day.parameters.scale_ratio - Eigen::Vector3d::Ones()).cwiseAbs().maxCoeff(), 0.01);
  EXPECT_LT(day.parameters.misalignment_deg.cwiseAbs().maxCoeff(), 2.0);
  int disagreements = 0;
  for (int i = 0; i < 4; ++i) {
    const auto& e = result.windows[i].estimate;
    EXPECT_EQ(e.quality, mic::Quality::kOk) << result.windows[i].label << ": " << e.quality_text;
    // Evaluated into matrices: an Eigen expression held in `auto` would keep references to
    // temporaries that are gone by the next line.
    const Eigen::Matrix<double, 9, 1> diff = (values(e.parameters) - values(day.parameters)).cwiseAbs();
    const Eigen::Matrix<double, 9, 1> allowed = half_widths(e.parameters) + half_widths(day.parameters);
    for (int k = 0; k < 9; ++k) {
      disagreements += diff(k) > allowed(k);
      if (diff(k) > allowed(k)) {
        ADD_FAILURE() << result.windows[i].label << " parameter " << k << ": " << values(e.parameters)(k)
                      << " vs day " << values(day.parameters)(k) << ", allowed " << allowed(k);
      }
    }
    // The day is more precise than each of its quarters.
    EXPECT_LT(half_widths(day.parameters).sum(), half_widths(e.parameters).sum());
    // A quarter holds 2 sections: its intervals take the jackknife over frequency groups; the
    // pair's reference noise is identified on each, and its uncertainty added (step 6d).
    EXPECT_EQ(e.intervals, "sandwich raised to the jackknife over 8 interleaved frequency groups, plus the identified "
                           "reference noise's uncertainty");
  }
  EXPECT_EQ(day.intervals, "sandwich raised to the jackknife over 8 sections, plus the identified reference noise's uncertainty");
  // 36 comparisons; honest intervals leave at most a few outside.
  EXPECT_LE(disagreements, 2);
}

TEST(WicRecords, SwappingTheRolesGivesTheInverse) {
  const mic::CalibrationSettings settings;
  const auto forward = mic::calibrate_records(wic().reference, wic().test, settings).windows[0].estimate;
  const auto backward = mic::calibrate_records(wic().test, wic().reference, settings).windows[0].estimate;
  const Eigen::Matrix3d product = forward.n * backward.n;
  const double tolerance = 2.0 * (forward.n_stderr().maxCoeff() + backward.n_stderr().maxCoeff());
  EXPECT_LT((product - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), tolerance) << product;
  // Misalignment of the swapped pair is the opposite rotation (orthogonal factor of n^-T).
  for (int l = 0; l < 3; ++l) {
    EXPECT_NEAR(forward.parameters.misalignment_deg(l), -backward.parameters.misalignment_deg(l),
                forward.parameters.misalignment_ci95_deg(l) + backward.parameters.misalignment_ci95_deg(l));
  }
}
