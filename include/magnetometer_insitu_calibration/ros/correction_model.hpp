// ROS-free part of correction_node: applying an accepted calibration matrix to test readings.
//
// Model (rows are samples): T = R n + d, so a test reading t (column vector, test frame) of the
// field r (column vector, reference frame) is t = n^T r + d, and the corrected reading is
//   r = n^-T (t - d)        (row form: r^T = (t - d)^T n^-1).
// d is the calibration's offset at its window end (offset_nT), held constant: the trend is NOT
// extrapolated beyond the window (a drift estimated over one window is too uncertain to
// extend; the next window brings the next offset). d = 0 gives the variations-only correction
// r = n^-T t. Units: d in the unit of t (the node converts nT to tesla).
//
// Uncertainty from n: the offset was estimated with n as d = mean(T) - n^T m, m = mean(R) over
// the window, so r = n^-T (t - mean(T)) + m (at the window centre) and an error dn of n moves r
// by -(r - m)^T dn n^-1 (row form), not by -r^T dn n^-1: at the window's mean field the offset
// absorbs n's error. With a main field of ~50 000 nT and |r - m| of tens of nT this is the
// difference between a stated uncertainty of nT and of hundredths of nT. `anchor` is m (zero:
// the whole field, the conservative form for calibrations without m or without the offset).
#pragma once

#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"

#include <Eigen/Core>

#include <string>

namespace magnetometer_insitu_calibration {

class CorrectionModel {
 public:
  /// Checks n (finite, invertible, condition number <= max_condition) and the covariance
  /// (finite, non-negative diagonal). Throws std::invalid_argument with the reason otherwise.
  /// offset: d (test frame, unit of t; must be finite); anchor: m, the reference mean of the
  /// calibration window (reference frame, unit of t; must be finite), see above.
  CorrectionModel(const Eigen::Matrix3d& n, const Matrix9d& covariance, double max_condition,
                  const Eigen::Vector3d& offset = Eigen::Vector3d::Zero(),
                  const Eigen::Vector3d& anchor = Eigen::Vector3d::Zero());

  /// r = n^-T (t - d), same unit as t.
  Eigen::Vector3d correct(const Eigen::Vector3d& test) const { return n_inverse_transpose_ * (test - offset_); }
  const Eigen::Vector3d& offset() const { return offset_; }

  /// Covariance of r (unit^2) from the covariance of t: n^-T C_t n^-1, plus, when
  /// include_calibration, the uncertainty of n itself propagated to first order:
  /// dr_j = -sum_ab (r - m)_a dn_ab (n^-1)_bj, i.e. J Cov(vec n) J^T with
  /// J_j,3a+b = -(r - m)_a (n^-1)_bj, m = anchor. (The offset's own noise terms, residual rms^2 / N
  /// and the trend's, are left out: they are small next to the test noise.)
  Eigen::Matrix3d corrected_covariance(const Eigen::Matrix3d& test_covariance, const Eigen::Vector3d& corrected,
                                       bool include_calibration) const;

  const Eigen::Matrix3d& n() const { return n_; }
  double condition_number() const { return condition_number_; }

 private:
  Eigen::Matrix3d n_;
  Eigen::Matrix3d n_inverse_;
  Eigen::Matrix3d n_inverse_transpose_;
  Matrix9d covariance_;
  Eigen::Vector3d offset_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d anchor_ = Eigen::Vector3d::Zero();
  double condition_number_ = 1.0;
};

}  // namespace magnetometer_insitu_calibration
