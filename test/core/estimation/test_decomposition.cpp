// Decomposition checked against matrices built from known angles (independently of the
// simulator's construction), and the delta-method intervals against sampling.
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "test_constants.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace mic = magnetometer_insitu_calibration;

namespace {
using magnetometer_insitu_calibration::test::kRad;

Eigen::Matrix3d rotation(double angle_deg, const Eigen::Vector3d& axis) {
  return Eigen::AngleAxisd(angle_deg * kRad, axis.normalized()).toRotationMatrix();
}
}  // namespace

TEST(Decomposition, IdentityIsPerfect) {
  const auto p = mic::decompose(Eigen::Matrix3d::Identity());
  EXPECT_NEAR((p.scale_ratio - Eigen::Vector3d::Ones()).norm(), 0.0, 1e-15);
  EXPECT_NEAR(p.nonorthogonality_deg.norm(), 0.0, 1e-12);
  EXPECT_NEAR(p.misalignment_deg.norm(), 0.0, 1e-12);
  EXPECT_NEAR(p.axis_deviation_deg.norm(), 0.0, 1e-12);
}

TEST(Decomposition, ScaleFactorsOnly) {
  const Eigen::Vector3d s(0.9996, 1.0004, 1.0004);  // the paper's coil-calibration ratios
  const auto p = mic::decompose(s.asDiagonal().toDenseMatrix());
  EXPECT_NEAR((p.scale_ratio - s).norm(), 0.0, 1e-15);
  EXPECT_NEAR(p.nonorthogonality_deg.norm(), 0.0, 1e-12);
  EXPECT_NEAR(p.misalignment_deg.norm(), 0.0, 1e-12);
}

TEST(Decomposition, PureRotationGivesMisalignmentAndAxisDeviation) {
  // The reference->test coordinate rotation Q = exp([theta]x); the test axes (columns of n) are
  // the columns of Q^T, so n = Q^T and n^T = Q.
  for (const Eigen::Vector3d axis : {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0),
                                     Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1, -2, 0.5)}) {
    for (double angle_deg : {0.01, 0.1, 0.5, 3.0}) {
      const Eigen::Matrix3d q = rotation(angle_deg, axis);
      const auto p = mic::decompose(Eigen::Matrix3d(q.transpose()));
      const Eigen::Vector3d expected = axis.normalized() * angle_deg;
      EXPECT_NEAR((p.misalignment_deg - expected).norm(), 0.0, 1e-9) << angle_deg;
      EXPECT_NEAR((p.scale_ratio - Eigen::Vector3d::Ones()).norm(), 0.0, 1e-13);
      EXPECT_NEAR(p.nonorthogonality_deg.norm(), 0.0, 1e-9);
      if (axis == Eigen::Vector3d(0, 0, 1)) {
        // About z, the x and y axes each turn by the full angle, z not at all.
        EXPECT_NEAR(p.axis_deviation_deg(0), angle_deg, 1e-9);
        EXPECT_NEAR(p.axis_deviation_deg(1), angle_deg, 1e-9);
        EXPECT_NEAR(p.axis_deviation_deg(2), 0.0, 1e-9);
      }
    }
  }
}

TEST(Decomposition, NonOrthogonalAxesFromKnownAngles) {
  // Test axes built in the reference frame with known angles:
  //   x along X; y in the XY plane at 90 - a from x; z tilted by b towards X and c towards Y.
  const double a = 0.02, b = -0.05, c = 0.3;  // degrees
  const Eigen::Vector3d ex(1, 0, 0);
  const Eigen::Vector3d ey(std::sin(a * kRad), std::cos(a * kRad), 0);
  Eigen::Vector3d ez(std::sin(b * kRad), std::sin(c * kRad), 1.0);
  ez.normalize();
  const Eigen::Vector3d s(1.0002, 0.9991, 1.0007);
  Eigen::Matrix3d n;
  n << s(0) * ex, s(1) * ey, s(2) * ez;
  const auto p = mic::decompose(n);
  EXPECT_NEAR((p.scale_ratio - s).norm(), 0.0, 1e-14);
  EXPECT_NEAR(p.nonorthogonality_deg(0), a, 1e-10);
  EXPECT_NEAR(p.nonorthogonality_deg(1), 90.0 - std::acos(ex.dot(ez)) / kRad, 1e-10);
  EXPECT_NEAR(p.nonorthogonality_deg(2), 90.0 - std::acos(ey.dot(ez)) / kRad, 1e-10);
  EXPECT_NEAR(p.axis_deviation_deg(0), 0.0, 1e-10);
  EXPECT_NEAR(p.axis_deviation_deg(1), a, 1e-10);
  EXPECT_NEAR(p.axis_deviation_deg(2), std::acos(ez.z()) / kRad, 1e-10);
  // Rotating the whole triad changes neither scale nor non-orthogonality.
  const Eigen::Matrix3d turned = rotation(0.7, Eigen::Vector3d(0.3, 1, -1)) * n;
  const auto q = mic::decompose(turned);
  EXPECT_NEAR((q.scale_ratio - s).norm(), 0.0, 1e-13);
  EXPECT_NEAR((q.nonorthogonality_deg - p.nonorthogonality_deg).norm(), 0.0, 1e-9);
}

TEST(Decomposition, PolarFactorIsOrthogonalAndExact) {
  const Eigen::Matrix3d q = rotation(1.3, Eigen::Vector3d(1, 2, 3));
  Eigen::Matrix3d p_sym;
  p_sym << 1.01, 0.002, -0.001, 0.002, 0.99, 0.003, -0.001, 0.003, 1.0;
  const Eigen::Matrix3d q_found = mic::polar_orthogonal_factor(q * p_sym);
  EXPECT_NEAR((q_found - q).norm(), 0.0, 1e-12);
}

TEST(Decomposition, DeltaMethodIntervalsMatchSampling) {
  // Draw vec(n) from N(n0, Sigma) and compare the spread of the derived values with the
  // delta-method half-widths / 1.96.
  const Eigen::Matrix3d n0 = rotation(0.2, Eigen::Vector3d(0, 0, 1)).transpose() *
                             Eigen::Vector3d(0.9996, 1.0004, 1.0004).asDiagonal();
  std::mt19937_64 rng(7);
  Eigen::Matrix<double, 9, 9> l = Eigen::Matrix<double, 9, 9>::Zero();
  std::normal_distribution<double> normal;
  for (int i = 0; i < 9; ++i)
    for (int j = 0; j <= i; ++j) l(i, j) = (i == j ? 2e-4 : 5e-5 * normal(rng));
  const mic::Matrix9d cov = l * l.transpose();
  const auto p = mic::decompose(n0, cov);

  const int draws = 20000;
  Eigen::Matrix<double, 12, 1> sum = Eigen::Matrix<double, 12, 1>::Zero(), sum2 = sum;
  for (int d = 0; d < draws; ++d) {
    Eigen::Matrix<double, 9, 1> z;
    for (int i = 0; i < 9; ++i) z(i) = normal(rng);
    const Eigen::Matrix<double, 9, 1> v = l * z;
    Eigen::Matrix3d n = n0;
    for (int k = 0; k < 9; ++k) n(k / 3, k % 3) += v(k);
    const auto q = mic::decompose(n);
    Eigen::Matrix<double, 12, 1> x;
    x << q.scale_ratio, q.nonorthogonality_deg, q.misalignment_deg, q.axis_deviation_deg;
    sum += x;
    sum2 += x.cwiseProduct(x);
  }
  const Eigen::Matrix<double, 12, 1> sd =
      (sum2 / draws - (sum / draws).cwiseProduct(sum / draws)).cwiseMax(0).cwiseSqrt();
  Eigen::Matrix<double, 9, 1> delta;
  delta << p.scale_ratio_ci95, p.nonorthogonality_ci95_deg, p.misalignment_ci95_deg;
  for (int i = 0; i < 9; ++i) {  // axis deviation (a norm near zero) is not symmetric: skipped
    EXPECT_NEAR(delta(i) / 1.959964 / sd(i), 1.0, 0.05) << "derived value " << i;
  }
}
