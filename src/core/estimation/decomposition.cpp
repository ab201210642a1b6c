// Decomposition of n (T = R n, column l = test axis l in reference coordinates).
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include <cmath>

namespace magnetometer_insitu_calibration {
namespace {

constexpr double kDegPerRad = 180.0 / M_PI;

/// Angle between two vectors, radians, stable for nearly (anti)parallel vectors.
double angle_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

/// All twelve derived values of n, in the order scale(3), nonorth(3), misalign(3), axisdev(3).
using Values12 = Eigen::Matrix<double, 12, 1>;

Values12 derived_values(const Eigen::Matrix3d& n) {
  Values12 v;
  for (int l = 0; l < 3; ++l) v(l) = n.col(l).norm();
  const int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};  // xy, xz, yz
  for (int p = 0; p < 3; ++p) {
    v(3 + p) = 90.0 - angle_between(n.col(pairs[p][0]), n.col(pairs[p][1])) * kDegPerRad;
  }
  v.segment<3>(6) = vector_from_rotation(polar_orthogonal_factor(n.transpose())) * kDegPerRad;
  for (int l = 0; l < 3; ++l) {
    v(9 + l) = angle_between(n.col(l), Eigen::Vector3d::Unit(l)) * kDegPerRad;
  }
  return v;
}

CalibrationParameters from_values(const Values12& v) {
  CalibrationParameters p;
  p.scale_ratio = v.segment<3>(0);
  p.nonorthogonality_deg = v.segment<3>(3);
  p.misalignment_deg = v.segment<3>(6);
  p.axis_deviation_deg = v.segment<3>(9);
  return p;
}

}  // namespace

Eigen::Matrix3d rotation_from_vector(const Eigen::Vector3d& rotation_vector_rad) {
  const double angle = rotation_vector_rad.norm();
  if (angle == 0.0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, rotation_vector_rad / angle).toRotationMatrix();
}

Eigen::Vector3d vector_from_rotation(const Eigen::Matrix3d& rotation) {
  // Eigen goes through a quaternion and takes angle = 2 atan2(|v|, w): stable at small angles.
  const Eigen::AngleAxisd aa(rotation);
  return aa.axis() * aa.angle();
}

Eigen::Matrix3d polar_orthogonal_factor(const Eigen::Matrix3d& m) {
  // M = U S V^T  =>  M = (U V^T)(V S V^T): Q = U V^T, P = V S V^T symmetric positive definite.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return svd.matrixU() * svd.matrixV().transpose();
}

CalibrationParameters decompose(const Eigen::Matrix3d& n) { return from_values(derived_values(n)); }

CalibrationParameters decompose(const Eigen::Matrix3d& n, const Matrix9d& covariance, double covariance_dof) {
  // Delta method: Cov(f(vec n)) ~= J Cov(vec n) J^T with J = d f / d vec(n) (12 x 9), taken by
  // central differences. The step is small against the entries of n (~1) and large against
  // rounding; the derived values are smooth except axis deviation at exactly zero (a norm),
  // where the interval is a one-sided bound rather than a symmetric one.
  const Values12 centre = derived_values(n);
  Eigen::Matrix<double, 12, 9> jacobian;
  const double h = 1e-6;
  for (int k = 0; k < 9; ++k) {
    Eigen::Matrix3d plus = n, minus = n;
    plus(k / 3, k % 3) += h;
    minus(k / 3, k % 3) -= h;
    jacobian.col(k) = (derived_values(plus) - derived_values(minus)) / (2.0 * h);
  }
  const Eigen::Matrix<double, 12, 12> cov = jacobian * covariance * jacobian.transpose();
  // No cells (a failed window): the normal quantile, the intervals being NaN or zero anyway.
  const double quantile =
      covariance_dof > 0.0 ? student_t_two_sided_quantile(0.05, covariance_dof) : kNormalQuantile95;
  const Values12 half_width = quantile * cov.diagonal().cwiseMax(0.0).cwiseSqrt();

  CalibrationParameters p = from_values(centre);
  p.interval_dof = covariance_dof;
  p.interval_quantile = quantile;
  p.scale_ratio_ci95 = half_width.segment<3>(0);
  p.nonorthogonality_ci95_deg = half_width.segment<3>(3);
  p.misalignment_ci95_deg = half_width.segment<3>(6);
  p.axis_deviation_ci95_deg = half_width.segment<3>(9);
  return p;
}

}  // namespace magnetometer_insitu_calibration
