// Self-consistency on the real WIC pair of 2025-05-14 (Conrad Observatory, CC-BY-4.0; see
// data/README.md): LEMI-036 reference, DTU FGE test. No truth is known for real instruments, so
// the checks are the ones an observatory would make: each 6-hour interval agrees with the whole
// day within what their intervals allow, and swapping the roles gives the inverse calibration.
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/estimation/window_agreement.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

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
  EXPECT_EQ(report.missing_samples, 0u);
  EXPECT_FALSE(report.decimated());
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
  // Each quarter against the day that contains it: the quarter's error minus the day's has
  // variance se_q^2 - se_day^2 (the day is the efficient combination of its quarters), so
  // z = (q - day) / sqrt(se_q^2 - se_day^2), se = half-width / interval_quantile. Honest intervals give z of
  // unit variance: over the 36 (4 quarters x 9 parameters) an rms near 1 (the real pair, whose
  // piers differ, was measured at 1.47 with the per-section trend column; about 1.3 over
  // the 35 defined without it), and no |z| beyond 4 (measured largest 3.28: the third quarter's misalignment
  // about z). Intervals half as wide as they should be would give an rms near 3.
  double sum_z2 = 0.0;
  for (int i = 0; i < 4; ++i) {
    const auto& e = result.windows[i].estimate;
    EXPECT_EQ(e.quality, mic::Quality::kOk) << result.windows[i].label << ": " << e.quality_text;
    // Evaluated into matrices: an Eigen expression held in `auto` would keep references to
    // temporaries that are gone by the next line.
    const Eigen::Matrix<double, 9, 1> se_q = half_widths(e.parameters) / e.parameters.interval_quantile;
    const Eigen::Matrix<double, 9, 1> se_day = half_widths(day.parameters) / day.parameters.interval_quantile;
    for (int k = 0; k < 9; ++k) {
      // A quarter is never more precise than the day that contains it (without the per-section
      // trend column the third quarter's H scale ratio was: +-0.00318 against the day's +-0.00358).
      ASSERT_GT(se_q(k), se_day(k)) << result.windows[i].label << " parameter " << k;
      const double z = (values(e.parameters)(k) - values(day.parameters)(k)) /
                       std::sqrt(se_q(k) * se_q(k) - se_day(k) * se_day(k));
      sum_z2 += z * z;
      EXPECT_LT(std::abs(z), 4.0) << result.windows[i].label << " parameter " << k << ": " << values(e.parameters)(k)
                                  << " vs day " << values(day.parameters)(k);
    }
    // A quarter holds 2 sections: its intervals take the jackknife over frequency groups; the
    // pair's reference noise is identified on each, and its uncertainty added (step 6d).
    EXPECT_EQ(e.intervals, "sandwich raised to the jackknife over 8 interleaved frequency groups, plus the identified "
                           "reference noise's uncertainty");
  }
  const double rms_z = std::sqrt(sum_z2 / 36.0);
  std::printf("quarters against the day: rms z %.2f over 36 parameters\n", rms_z);
  EXPECT_LT(rms_z, 2.0);
  EXPECT_EQ(day.intervals, "sandwich raised to the jackknife over 8 sections, plus the identified reference noise's uncertainty");
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

TEST(WicRecords, TheQuartersAgreeWithinTheDefaultsIntervalsAndNotWithinPlainEq2s) {
  // The check an observatory reads in the report (window_agreement.hpp): do the four quarters
  // scatter as their intervals say? The default's do (measured joint chi2 39.3 / 27 dof, p 0.09;
  // largest sqrt(chi2/3.03) 1.60, Z scale, p 0.05; p 0.06 with the covariances taken as
  // known). Plain Eq. 2's sandwich on 6-hour windows is known to be optimistic
  // (docs/validation.md, window agreement): its quarters scatter beyond it (measured joint p
  // below 1e-5), which the check must say.
  mic::CalibrationSettings settings;
  settings.windows.intervals = 4;
  const auto agreement = [&settings] {
    const mic::PairCalibration day = mic::calibrate_records(wic().reference, wic().test, settings);
    return mic::check_window_agreement(mic::disjoint_window_estimates(day.windows));
  };
  const mic::WindowAgreement robust = agreement();
  std::printf("default: %s\n", robust.text.c_str());
  ASSERT_TRUE(robust.assessed) << robust.text;
  EXPECT_EQ(robust.windows, 4);
  EXPECT_TRUE(robust.agree) << robust.text;
  EXPECT_GT(robust.joint_p_value, 0.01) << robust.text;
  settings.window.estimator.method = mic::EstimatorMethod::kPlain;
  settings.window.response_model = false;  // as calibrate_records --method plain
  const mic::WindowAgreement plain = agreement();
  std::printf("plain Eq. 2: %s\n", plain.text.c_str());
  ASSERT_TRUE(plain.assessed) << plain.text;
  EXPECT_FALSE(plain.agree) << plain.text;
  EXPECT_LT(plain.joint_p_value, 1e-4) << plain.text;
}
