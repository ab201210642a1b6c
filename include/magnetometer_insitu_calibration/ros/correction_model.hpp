// ROS-free part of correction_node: applying an accepted calibration matrix to test readings.
//
// Model (rows are samples): T = R n, so a test reading t (column vector, test frame) of the
// field r (column vector, reference frame) is t = n^T r, and the corrected reading is
//   r = n^-T t        (row form: r^T = t^T n^-1).
// The unit does not matter (linear): tesla in, tesla out.
#pragma once

#include "magnetometer_insitu_calibration/decomposition.hpp"

#include <Eigen/Core>

#include <string>

namespace magnetometer_insitu_calibration {

class CorrectionModel {
 public:
  /// Checks n (finite, invertible, condition number <= max_condition) and the covariance
  /// (finite, non-negative diagonal). Throws std::invalid_argument with the reason otherwise.
  CorrectionModel(const Eigen::Matrix3d& n, const Matrix9d& covariance, double max_condition);

  /// r = n^-T t, same unit as t.
  Eigen::Vector3d correct(const Eigen::Vector3d& test) const { return n_inverse_transpose_ * test; }

  /// Covariance of r (unit^2) from the covariance of t: n^-T C_t n^-1, plus, when
  /// include_calibration, the uncertainty of n itself propagated to first order:
  /// dr_j = -sum_ab r_a dn_ab (n^-1)_bj, i.e. J Cov(vec n) J^T with J_j,3a+b = -r_a (n^-1)_bj.
  Eigen::Matrix3d corrected_covariance(const Eigen::Matrix3d& test_covariance, const Eigen::Vector3d& corrected,
                                       bool include_calibration) const;

  const Eigen::Matrix3d& n() const { return n_; }
  double condition_number() const { return condition_number_; }

 private:
  Eigen::Matrix3d n_;
  Eigen::Matrix3d n_inverse_;
  Eigen::Matrix3d n_inverse_transpose_;
  Matrix9d covariance_;
  double condition_number_ = 1.0;
};

}  // namespace magnetometer_insitu_calibration
