// Forward model of the calibration matrix: see calibration_matrix.hpp.
#include "magnetometer_insitu_calibration/estimation/calibration_matrix.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <cmath>
#include <sstream>
#include <string>

namespace magnetometer_insitu_calibration {
namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

std::string text_of(const Eigen::Vector3d& v) {
  std::ostringstream out;
  out << v(0) << ", " << v(1) << ", " << v(2);
  return out.str();
}

void require_finite(const Eigen::Vector3d& v, const char* name) {
  if (!v.allFinite()) {
    std::ostringstream text;
    text << "values must be finite, got " << text_of(v);
    throw InputError(name, text.str());
  }
}

}  // namespace

Eigen::Matrix3d unit_triad_from_nonorthogonality(const Eigen::Vector3d& nonorthogonality_deg) {
  require_finite(nonorthogonality_deg, "nonorthogonality_deg");
  // Gram matrix of the unit axes: cos(90 deg - a) = sin(a).
  const double sxy = std::sin(nonorthogonality_deg(0) * kDegToRad);
  const double sxz = std::sin(nonorthogonality_deg(1) * kDegToRad);
  const double syz = std::sin(nonorthogonality_deg(2) * kDegToRad);
  Eigen::Matrix3d gram;
  gram << 1.0, sxy, sxz,  //
      sxy, 1.0, syz,      //
      sxz, syz, 1.0;
  if ((nonorthogonality_deg.array().abs() >= 90.0).any()) {
    throw InputError("nonorthogonality_deg", "each angle must lie in (-90, 90) degrees");
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(gram);
  if (eigen.info() != Eigen::Success || eigen.eigenvalues().minCoeff() <= 1e-12) {
    std::ostringstream text;
    text << "angles " << text_of(nonorthogonality_deg)
         << " deg do not describe three independent axes";
    throw InputError("nonorthogonality_deg", text.str());
  }
  // Symmetric square root: U = V sqrt(D) V^T, so U^T U = G and U is the closest such triad to I.
  const Eigen::Matrix3d& v = eigen.eigenvectors();
  Eigen::Matrix3d root = v * eigen.eigenvalues().cwiseSqrt().asDiagonal() * v.transpose();
  root = 0.5 * (root + root.transpose());
  // Make each column exactly unit length (removes the last rounding of the square root).
  for (int l = 0; l < 3; ++l) root.col(l).normalize();
  return root;
}

Eigen::Matrix3d rotation_from_vector_deg(const Eigen::Vector3d& rotation_vector_deg) {
  const Eigen::Vector3d v = rotation_vector_deg * kDegToRad;
  const double angle = v.norm();
  if (angle == 0.0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, v / angle).toRotationMatrix();
}

Eigen::Matrix3d matrix_from_angles(const Eigen::Vector3d& scale_ratio,
                                   const Eigen::Vector3d& nonorthogonality_deg,
                                   const Eigen::Vector3d& misalignment_deg) {
  require_finite(scale_ratio, "scale_ratio");
  require_finite(misalignment_deg, "misalignment_deg");
  if ((scale_ratio.array() <= 0.0).any()) {
    std::ostringstream text;
    text << "scale ratios must be positive, got " << text_of(scale_ratio);
    throw InputError("scale_ratio", text.str());
  }
  const Eigen::Matrix3d triad = unit_triad_from_nonorthogonality(nonorthogonality_deg);
  const Eigen::Matrix3d q = rotation_from_vector_deg(misalignment_deg);  // reference -> test
  Eigen::Matrix3d n = q.transpose() * triad;
  // Rotation preserves norms only to rounding: renormalise so |column l| == scale_ratio(l).
  for (int l = 0; l < 3; ++l) n.col(l) *= scale_ratio(l) / n.col(l).norm();
  return n;
}

}  // namespace magnetometer_insitu_calibration
