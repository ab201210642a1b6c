// Known-truth tests of matrix_from_angles: column norms, pairwise angles, misalignment sense.
#include "magnetometer_insitu_calibration/estimation/calibration_matrix.hpp"
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  // atan2 form: accurate at every angle (acos loses digits near 0 and 180 deg).
  return std::atan2(a.cross(b).norm(), a.dot(b)) * kRadToDeg;
}

// Orthogonal polar factor of m (m = Q P), by SVD: independent of decomposition.cpp.
Eigen::Matrix3d polar_factor(const Eigen::Matrix3d& m) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return svd.matrixU() * svd.matrixV().transpose();
}

Eigen::Vector3d rotation_vector_deg(const Eigen::Matrix3d& rotation) {
  const Eigen::AngleAxisd aa(rotation);
  return aa.axis() * aa.angle() * kRadToDeg;
}

struct Case {
  Eigen::Vector3d scale, nonorth_deg, misalign_deg;
};

std::vector<Case> cases() {
  return {
      {{0.9996, 1.0004, 1.0004}, {0.01, 0.0, 0.02}, {0.05, -0.1, 0.3}},  // paper-like
      {{1.0, 1.0, 1.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}},
      {{0.5, 2.0, 1.3}, {3.0, -5.0, 12.0}, {10.0, 20.0, -30.0}},
      {{1.1, 0.9, 1.05}, {-0.5, 0.25, -0.125}, {-0.4, 0.0, 0.45}},
      {{1.0, 1.0, 1.0}, {40.0, 30.0, 20.0}, {0.0, 90.0, 0.0}},
  };
}

}  // namespace

TEST(CalibrationMatrix, ColumnNormsAreScaleRatiosAndAnglesAreNonorthogonality) {
  for (const Case& c : cases()) {
    const Eigen::Matrix3d n = mic::matrix_from_angles(c.scale, c.nonorth_deg, c.misalign_deg);
    for (int l = 0; l < 3; ++l) EXPECT_NEAR(n.col(l).norm(), c.scale(l), 1e-12) << "column " << l;
    EXPECT_NEAR(90.0 - angle_deg(n.col(0), n.col(1)), c.nonorth_deg(0), 1e-12);
    EXPECT_NEAR(90.0 - angle_deg(n.col(0), n.col(2)), c.nonorth_deg(1), 1e-12);
    EXPECT_NEAR(90.0 - angle_deg(n.col(1), n.col(2)), c.nonorth_deg(2), 1e-12);
  }
}

TEST(CalibrationMatrix, TriadIsSymmetricSquareRootOfGram) {
  const Eigen::Vector3d a(0.3, -0.2, 0.5);
  const Eigen::Matrix3d u = mic::unit_triad_from_nonorthogonality(a);
  EXPECT_LT((u - u.transpose()).cwiseAbs().maxCoeff(), 1e-15);
  const double d2r = 1.0 / kRadToDeg;
  Eigen::Matrix3d gram;
  gram << 1, std::sin(a(0) * d2r), std::sin(a(1) * d2r),  //
      std::sin(a(0) * d2r), 1, std::sin(a(2) * d2r),      //
      std::sin(a(1) * d2r), std::sin(a(2) * d2r), 1;
  EXPECT_LT((u.transpose() * u - gram).cwiseAbs().maxCoeff(), 1e-14);
  // Close to the identity: each off-diagonal is half the Gram term to first order.
  EXPECT_NEAR(u(0, 1), 0.5 * std::sin(a(0) * d2r), 1e-5);
  EXPECT_NEAR(u(1, 2), 0.5 * std::sin(a(2) * d2r), 1e-5);
  EXPECT_LT((mic::unit_triad_from_nonorthogonality(Eigen::Vector3d::Zero()) -
             Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 0.0 + 1e-16);
}

TEST(CalibrationMatrix, MisalignmentIsExactPolarFactorWithoutNonorthogonality) {
  const std::vector<Eigen::Vector3d> rotations = {
      {0.05, -0.1, 0.3}, {0.0, 0.0, 0.0}, {1.0, 2.0, -3.0}, {-20.0, 5.0, 7.5}};
  const Eigen::Vector3d scale(0.9996, 1.0004, 1.0004);
  for (const auto& v : rotations) {
    const Eigen::Matrix3d n = mic::matrix_from_angles(scale, Eigen::Vector3d::Zero(), v);
    // n^T = Q P with Q the reference -> test rotation exp([v]x).
    const Eigen::Matrix3d q = polar_factor(n.transpose());
    EXPECT_LT((q - mic::rotation_from_vector_deg(v)).cwiseAbs().maxCoeff(), 1e-13);
    EXPECT_LT((rotation_vector_deg(q) - v).cwiseAbs().maxCoeff(), 1e-10) << v.transpose();
  }
}

TEST(CalibrationMatrix, MisalignmentSenseAboutZ) {
  // Q = Rz(theta) takes reference coordinates to test coordinates, so test axis x seen from the
  // reference is the first row of Q: (cos, -sin, 0); test axis y is (sin, cos, 0).
  const double theta_deg = 2.0;
  const double t = theta_deg / kRadToDeg;
  const Eigen::Matrix3d n = mic::matrix_from_angles(Eigen::Vector3d::Ones(), Eigen::Vector3d::Zero(),
                                                    Eigen::Vector3d(0, 0, theta_deg));
  EXPECT_NEAR(n(0, 0), std::cos(t), 1e-15);
  EXPECT_NEAR(n(1, 0), -std::sin(t), 1e-15);
  EXPECT_NEAR(n(0, 1), std::sin(t), 1e-15);
  EXPECT_NEAR(n(1, 1), std::cos(t), 1e-15);
  EXPECT_NEAR(n(2, 2), 1.0, 1e-15);
  // A field along reference x reads cos(theta) on test x and sin(theta) on test y: T = R n.
  const Eigen::RowVector3d reading = Eigen::RowVector3d(1, 0, 0) * n;
  EXPECT_NEAR(reading(1), std::sin(t), 1e-15);
}

TEST(CalibrationMatrix, RejectsImpossibleInput) {
  const Eigen::Vector3d ones = Eigen::Vector3d::Ones(), zero = Eigen::Vector3d::Zero();
  try {
    mic::matrix_from_angles(Eigen::Vector3d(1, 0, 1), zero, zero);
    FAIL() << "zero scale accepted";
  } catch (const mic::InputError& e) {
    EXPECT_EQ(e.where(), "scale_ratio");
  }
  try {
    mic::matrix_from_angles(ones, Eigen::Vector3d(89.0, 89.0, -89.0), zero);
    FAIL() << "dependent axes accepted";
  } catch (const mic::InputError& e) {
    EXPECT_EQ(e.where(), "nonorthogonality_deg");
  }
  try {
    mic::matrix_from_angles(ones, Eigen::Vector3d(90.0, 0.0, 0.0), zero);
    FAIL() << "90 deg accepted";
  } catch (const mic::InputError& e) {
    EXPECT_EQ(e.where(), "nonorthogonality_deg");
  }
  try {
    mic::matrix_from_angles(ones, zero, Eigen::Vector3d(0, NAN, 0));
    FAIL() << "NaN accepted";
  } catch (const mic::InputError& e) {
    EXPECT_EQ(e.where(), "misalignment_deg");
  }
}

TEST(CalibrationMatrix, DecompositionRecoversTheConstruction) {
  // decompose() (decomposition.cpp) is the inverse of matrix_from_angles for scale ratios and
  // non-orthogonality always, and for the misalignment when the axes are orthogonal.
  for (const Case& c : cases()) {
    const mic::CalibrationParameters p =
        mic::decompose(mic::matrix_from_angles(c.scale, c.nonorth_deg, c.misalign_deg));
    EXPECT_LT((p.scale_ratio - c.scale).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((p.nonorthogonality_deg - c.nonorth_deg).cwiseAbs().maxCoeff(), 1e-10);
    const mic::CalibrationParameters q =
        mic::decompose(mic::matrix_from_angles(c.scale, Eigen::Vector3d::Zero(), c.misalign_deg));
    EXPECT_LT((q.misalignment_deg - c.misalign_deg).cwiseAbs().maxCoeff(), 1e-10);
  }
}
