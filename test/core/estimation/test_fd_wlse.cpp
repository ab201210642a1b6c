// FD-WLSE (Eq. 2): the literal formula of the paper as an oracle, recovery of a known n,
// the trend column against a linear drift, interval coverage, and the quality rules.
// Records here come from a small local generator (random-walk field, PSD ~ f^-2, plus white and
// AR(1) noise) so that the estimator is tested independently of the package's simulator.
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "test_constants.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <cstdio>
#include <iostream>
#include <random>

namespace mic = magnetometer_insitu_calibration;
using mic::Readings;

namespace {

using magnetometer_insitu_calibration::test::kRad;

struct Pair {
  Readings reference, test;
};

struct Recipe {
  std::size_t samples = 21600;           // 6 h at 1 Hz
  Eigen::Matrix3d n = Eigen::Matrix3d::Identity();
  double step_nT = 0.3;                  // random-walk step per sample, X and Y
  double z_ratio = 0.5;                  // Z variation relative to X, Y
  double noise_reference_nT = 0.005;     // white, per sample
  double noise_test_nT = 0.05;           // white, per sample
  double ar1_test_nT = 0.0;              // AR(1) (phi = 0.995) innovation, coloured test noise
  Eigen::Vector3d drift_nT_per_day = Eigen::Vector3d::Zero();
  std::uint64_t seed = 1;
};

Pair make_pair(const Recipe& r) {
  std::mt19937_64 rng(r.seed);
  std::normal_distribution<double> normal;
  Readings field(r.samples, 3);
  Eigen::Vector3d b(20.0, -5.0, 10.0);
  Eigen::Matrix3d mix;  // correlated components, as H and Z often are
  mix << 1.0, 0.2, 0.0, 0.0, 1.0, 0.0, 0.3, -0.1, r.z_ratio;
  for (std::size_t i = 0; i < r.samples; ++i) {
    const Eigen::Vector3d step(normal(rng), normal(rng), normal(rng));
    b += r.step_nT * mix * step;
    field.row(i) = b.transpose();
  }
  Pair p;
  p.reference = field;
  p.test = field * r.n;
  Eigen::Vector3d ar = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < r.samples; ++i) {
    const double days = static_cast<double>(i) / 86400.0;
    for (int k = 0; k < 3; ++k) {
      ar(k) = 0.995 * ar(k) + r.ar1_test_nT * normal(rng);
      p.reference(i, k) += r.noise_reference_nT * normal(rng);
      p.test(i, k) += r.noise_test_nT * normal(rng) + ar(k) + r.drift_nT_per_day(k) * days;
    }
  }
  return p;
}

Eigen::Matrix3d known_matrix() {
  // Scale ratios of the paper's instruments, angles of 0.01 to 0.5 degrees.
  const Eigen::Matrix3d q =
      Eigen::AngleAxisd(0.5 * kRad, Eigen::Vector3d(0.2, 0.3, 1.0).normalized()).toRotationMatrix();
  Eigen::Matrix3d axes;
  axes << 1.0, std::sin(0.01 * kRad), std::sin(0.05 * kRad),  //
      0.0, std::cos(0.01 * kRad), std::sin(-0.03 * kRad),      //
      0.0, 0.0, 1.0;
  for (int l = 0; l < 3; ++l) axes.col(l).normalize();
  return q.transpose() * axes * Eigen::Vector3d(0.9996, 1.0004, 1.0004).asDiagonal();
}

/// Eq. 2 exactly as printed: w(lambda) = (2 pi N)^-1/2 sum_{t=1..N} x(t) e^{i t lambda},
/// I_kl = w_k w_l^*, n = (1/m sum lambda^g Re I_XX)^-1 (1/m sum lambda^g Re I_XT), j = m0..m,
/// regressors [R, t] with a linear-trend column.
Eigen::Matrix3d literal_eq2(const Pair& p, long m0, long m, double gamma) {
  const long n = p.reference.rows();
  Eigen::MatrixXd x(n, 4);
  x.leftCols(3) = p.reference;
  for (long t = 0; t < n; ++t) x(t, 3) = static_cast<double>(t + 1);
  Eigen::Matrix4d a = Eigen::Matrix4d::Zero();
  Eigen::Matrix<double, 4, 3> c = Eigen::Matrix<double, 4, 3>::Zero();
  const std::complex<double> i(0.0, 1.0);
  const double norm = 1.0 / std::sqrt(2.0 * M_PI * n);
  for (long j = m0; j <= m; ++j) {
    const double lambda = 2.0 * M_PI * j / n;
    Eigen::Vector4cd wx = Eigen::Vector4cd::Zero();
    Eigen::Vector3cd wt = Eigen::Vector3cd::Zero();
    for (long t = 1; t <= n; ++t) {
      const std::complex<double> e = std::exp(i * (double(t) * lambda));
      for (int k = 0; k < 4; ++k) wx(k) += x(t - 1, k) * e;
      for (int k = 0; k < 3; ++k) wt(k) += p.test(t - 1, k) * e;
    }
    wx *= norm;
    wt *= norm;
    const double g = std::pow(lambda, gamma) / double(m - m0 + 1);
    for (int k = 0; k < 4; ++k) {
      for (int l = 0; l < 4; ++l) a(k, l) += g * (wx(k) * std::conj(wx(l))).real();
      for (int l = 0; l < 3; ++l) c(k, l) += g * (wx(k) * std::conj(wt(l))).real();
    }
  }
  return (a.inverse() * c).topRows(3);
}

}  // namespace

TEST(FdWlse, MatchesEquation2AsPrinted) {
  Recipe r;
  r.samples = 1500;
  r.n = known_matrix();
  r.noise_test_nT = 0.5;  // a visible residual, so that any difference in weighting shows
  r.drift_nT_per_day = Eigen::Vector3d(30, -10, 5);
  const Pair p = make_pair(r);
  for (double gamma : {0.0, 1.0, 1.7}) {
    mic::EstimatorSettings s;
    s.band_low_hz = 0.003;
    s.band_high_hz = 0.1;
    s.gamma = gamma;
    mic::FdWlseEstimator estimator(s);
    const mic::WindowEstimate e = estimator.estimate(p.reference, p.test, 1.0);
    EXPECT_EQ(e.harmonic_first, 5);   // ceil(0.003 * 1500)
    EXPECT_EQ(e.harmonic_last, 150);  // floor(0.1 * 1500)
    const Eigen::Matrix3d oracle = literal_eq2(p, 5, 150, gamma);
    EXPECT_LT((e.n - oracle).cwiseAbs().maxCoeff(), 1e-9) << "gamma " << gamma;
  }
}

TEST(FdWlse, RecoversKnownMatrixWithinThreeStandardErrors) {
  Recipe r;
  r.n = known_matrix();
  r.ar1_test_nT = 0.002;  // coloured (AR(1), phi = 0.995) test noise on top of the white
  const Pair p = make_pair(r);
  mic::FdWlseEstimator estimator;
  const mic::WindowEstimate e = estimator.estimate(p.reference, p.test, 1.0);
  ASSERT_EQ(e.quality, mic::Quality::kOk) << e.quality_text;
  const Eigen::Matrix3d se = e.n_stderr();
  for (int k = 0; k < 9; ++k) {
    const int row = k / 3, col = k % 3;
    EXPECT_LT(std::abs(e.n(row, col) - r.n(row, col)), 3.0 * se(row, col)) << "n(" << row << "," << col << ")";
    EXPECT_LT(se(row, col), 1e-3);  // the estimate is informative, not trivially wide
    EXPECT_GT(se(row, col), 0.0);
  }
  const mic::CalibrationParameters truth = mic::decompose(r.n);
  for (int l = 0; l < 3; ++l) {
    EXPECT_LT(std::abs(e.parameters.scale_ratio(l) - truth.scale_ratio(l)), e.parameters.scale_ratio_ci95(l) * 1.6);
    EXPECT_LT(std::abs(e.parameters.misalignment_deg(l) - truth.misalignment_deg(l)), e.parameters.misalignment_ci95_deg(l) * 1.6);
  }
  EXPECT_GT(e.coherence.minCoeff(), 0.99);
  EXPECT_LT(e.condition_number, 100.0);
}

TEST(FdWlse, TrendColumnKeepsLinearDriftOutOfTheMatrix) {
  Recipe r;
  r.n = known_matrix();
  r.drift_nT_per_day = Eigen::Vector3d(40.0, -25.0, 60.0);  // large baseline drift of the test
  const Pair p = make_pair(r);

  mic::FdWlseEstimator with_trend;  // trend column on by default
  const mic::WindowEstimate e = with_trend.estimate(p.reference, p.test, 1.0);
  const Eigen::Matrix3d se = e.n_stderr();
  for (int k = 0; k < 9; ++k) {
    EXPECT_LT(std::abs(e.n(k / 3, k % 3) - r.n(k / 3, k % 3)), 3.0 * se(k / 3, k % 3)) << k;
  }
  for (int l = 0; l < 3; ++l) {
    EXPECT_NEAR(e.trend_nT_per_day(l), r.drift_nT_per_day(l), 3.0 * e.trend_stderr_nT_per_day(l));
  }

  mic::EstimatorSettings no_trend_settings;
  no_trend_settings.trend = false;
  mic::FdWlseEstimator without_trend(no_trend_settings);
  const mic::WindowEstimate biased = without_trend.estimate(p.reference, p.test, 1.0);
  // Without the column the drift leaks into the band and is taken for field: some entry of n
  // is off by many of its standard errors.
  const Eigen::Matrix3d z = (biased.n - r.n).cwiseQuotient(biased.n_stderr()).cwiseAbs();
  EXPECT_GT(z.maxCoeff(), 5.0);
}

TEST(FdWlse, IntervalsCoverTheTruthAtTheNominalRate) {
  // 200 records with white + AR(1) coloured test noise; every n entry, scale ratio,
  // non-orthogonality and misalignment interval is checked.
  const int records = 200;
  int covered = 0, checked = 0;
  Eigen::Matrix3d sum_err = Eigen::Matrix3d::Zero(), sum_err2 = sum_err, sum_var = sum_err;
  mic::FdWlseEstimator estimator;
  const Eigen::Matrix3d n = known_matrix();
  const mic::CalibrationParameters truth = mic::decompose(n);
  for (int s = 0; s < records; ++s) {
    Recipe r;
    r.samples = 21600;  // 6 h, as the paper's shortest intervals
    r.n = n;
    r.ar1_test_nT = 0.02;
    r.seed = 1000 + s;
    const Pair p = make_pair(r);
    const mic::WindowEstimate e = estimator.estimate(p.reference, p.test, 1.0);
    const Eigen::Matrix3d se = e.n_stderr();
    for (int k = 0; k < 9; ++k) {
      const double err = e.n(k / 3, k % 3) - n(k / 3, k % 3);
      covered += std::abs(err) <= 1.959964 * se(k / 3, k % 3);
      ++checked;
      sum_err(k / 3, k % 3) += err;
      sum_err2(k / 3, k % 3) += err * err;
      sum_var(k / 3, k % 3) += se(k / 3, k % 3) * se(k / 3, k % 3);
    }
    const auto& q = e.parameters;
    for (int l = 0; l < 3; ++l) {
      covered += std::abs(q.scale_ratio(l) - truth.scale_ratio(l)) <= q.scale_ratio_ci95(l);
      covered += std::abs(q.nonorthogonality_deg(l) - truth.nonorthogonality_deg(l)) <= q.nonorthogonality_ci95_deg(l);
      covered += std::abs(q.misalignment_deg(l) - truth.misalignment_deg(l)) <= q.misalignment_ci95_deg(l);
      checked += 3;
    }
  }
  const double coverage = double(covered) / checked;
  EXPECT_GE(coverage, 0.92);
  EXPECT_LE(coverage, 0.98);
  // The stated standard errors match the actual scatter across records (within 20 %).
  const Eigen::Matrix3d ratio = (sum_err2 / records).cwiseQuotient(sum_var / records).cwiseSqrt();
  EXPECT_GT(ratio.minCoeff(), 0.8) << ratio;
  EXPECT_LT(ratio.maxCoeff(), 1.2) << ratio;
  RecordProperty("coverage", std::to_string(coverage));
  std::printf("coverage %.4f; scatter / stated stderr:\n", coverage);
  std::cout << ratio << std::endl;
}

TEST(FdWlse, QualityRulesFlagWindowsWithoutEnoughSignal) {
  Recipe r;
  r.n = known_matrix();
  mic::FdWlseEstimator estimator;

  r.z_ratio = 0.0;  // no vertical variation at all: A is (nearly) singular in Z
  Pair p = make_pair(r);
  p.reference.col(2).setConstant(5.0);
  p.test = p.reference * r.n;
  EXPECT_EQ(estimator.estimate(p.reference, p.test, 1.0).quality, mic::Quality::kIllConditioned);

  r.z_ratio = 0.5;
  p = make_pair(r);
  Recipe other = r;
  other.seed = 99;
  const Pair unrelated = make_pair(other);  // test does not see the reference's field
  const auto low = estimator.estimate(p.reference, unrelated.test, 1.0);
  EXPECT_EQ(low.quality, mic::Quality::kLowCoherence) << low.quality_text;

  const auto short_window = estimator.estimate(p.reference.topRows(500), p.test.topRows(500), 1.0);
  EXPECT_EQ(short_window.quality, mic::Quality::kTooFewSamples);  // 500 s: harmonics 1..5 only
  EXPECT_TRUE(std::isnan(short_window.n(0, 0)));

  const auto few = estimator.estimate(p.reference.topRows(1500), p.test.topRows(1500), 1.0);
  EXPECT_EQ(few.quality, mic::Quality::kTooFewHarmonics);  // harmonics 1..15 < min_harmonics 16
  EXPECT_TRUE(std::isfinite(few.n(0, 0)));  // estimated, but flagged

  p.test(100, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(estimator.estimate(p.reference, p.test, 1.0).quality, mic::Quality::kNotFinite);
}

TEST(FdWlse, SettingsValidationNamesTheField) {
  mic::EstimatorSettings s;
  s.band_high_hz = s.band_low_hz;
  try {
    mic::FdWlseEstimator e(s);
    FAIL() << "empty band accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("band_high_hz"), std::string::npos) << e.what();
  }
}
