// Decomposition of the calibration matrix n into scale-factor ratios, non-orthogonality,
// misalignment and axis deviations, with 95 % intervals by the delta method: +- a Student t
// quantile times the standard error, the t's degrees of freedom those of the covariance.
//
// Convention (as in Marusenkov et al., Eq. 1, rows are samples): T = R n, so test reading l is
// the projection of the field (reference coordinates) on column l of n: column l of n is test
// axis l expressed in the reference frame, and n^T maps reference-frame coordinates of a vector
// to test-frame coordinates.
#pragma once

#include <Eigen/Core>

#include <limits>

namespace magnetometer_insitu_calibration {

using Matrix9d = Eigen::Matrix<double, 9, 9>;

/// Two-sided 95 % quantile of the normal distribution: the half-width of a 95 % interval in
/// standard errors when the covariance is taken as known.
constexpr double kNormalQuantile95 = 1.959963984540054;

/// Index of n(row, col) in vec(n): row-major, k = 3 * row + col (as in the JSON "matrix").
constexpr int vec_index(int row, int col) { return 3 * row + col; }

struct CalibrationParameters {
  /// K_test,l / K_ref,l = |column l of n|.
  Eigen::Vector3d scale_ratio = Eigen::Vector3d::Ones();
  /// xy, xz, yz: 90 deg minus the angle between unit test axes (positive = axes closer than 90).
  Eigen::Vector3d nonorthogonality_deg = Eigen::Vector3d::Zero();
  /// Rotation vector (axis * angle, degrees; components about reference x, y, z) of Q, the
  /// orthogonal factor of the polar decomposition n^T = Q P (P symmetric positive definite).
  /// Q takes reference-frame coordinates to test-frame coordinates.
  Eigen::Vector3d misalignment_deg = Eigen::Vector3d::Zero();
  /// Angle between unit test axis l and reference axis l, degrees (>= 0).
  Eigen::Vector3d axis_deviation_deg = Eigen::Vector3d::Zero();

  // Half-widths of the 95 % intervals (value +- ci95), same units as the values.
  Eigen::Vector3d scale_ratio_ci95 = Eigen::Vector3d::Zero();
  Eigen::Vector3d nonorthogonality_ci95_deg = Eigen::Vector3d::Zero();
  Eigen::Vector3d misalignment_ci95_deg = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_deviation_ci95_deg = Eigen::Vector3d::Zero();

  /// Degrees of freedom behind the intervals: the spectral cells n's covariance rests on
  /// (WindowEstimate::covariance_dof); infinite when the covariance is taken as known.
  double interval_dof = std::numeric_limits<double>::infinity();
  /// Half-width of each 95 % interval in standard errors: Student's t two-sided 5 % quantile with
  /// interval_dof degrees of freedom (1.960 when infinite, 2.064 at 24 cells, 2.228 at 10). A
  /// parameter's standard error is its ci95 / interval_quantile.
  double interval_quantile = kNormalQuantile95;
};

/// Point values only (no intervals).
CalibrationParameters decompose(const Eigen::Matrix3d& n);

/// Point values and 95 % intervals from the 9x9 covariance of row-major vec(n), by the delta
/// method: the Jacobian of the decomposition is taken by central differences. covariance_dof: the
/// covariance's degrees of freedom (spectral cells); the half-widths are Student's t quantile
/// with as many degrees of freedom times the standard errors (the normal's 1.960 when infinite).
/// A covariance from few cells is itself uncertain: with the normal quantile an interval from 10
/// cells would cover 92 %, its half-width 12 % too narrow (docs/validation.md, coverage).
CalibrationParameters decompose(const Eigen::Matrix3d& n, const Matrix9d& covariance,
                                double covariance_dof = std::numeric_limits<double>::infinity());

/// Rotation matrix from a rotation vector (radians), and back (the principal logarithm).
Eigen::Matrix3d rotation_from_vector(const Eigen::Vector3d& rotation_vector_rad);
Eigen::Vector3d vector_from_rotation(const Eigen::Matrix3d& rotation);

/// Orthogonal factor Q of the polar decomposition M = Q P (M non-singular).
Eigen::Matrix3d polar_orthogonal_factor(const Eigen::Matrix3d& m);

}  // namespace magnetometer_insitu_calibration
