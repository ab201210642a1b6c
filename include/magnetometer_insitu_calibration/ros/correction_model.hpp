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
//
// Temperature terms (estimation/temperature_regression.hpp; optional): the calibration's model
// per test component l, with u = theta - theta_ref (theta the test sensor's temperature, theta_ref
// the calibration's temperature_reference_C, deg C):
//   t_l = (n^T r)_l (1 + s_l u) + c_l u + d_l
// (s_l in 1/degC, c_l in the unit of t per degC). Its exact inverse, applied by correct(t, theta):
//   y_l = (t_l - d_l - c_l u) / (1 + s_l u),   r = n^-T y.
// (To first order this removes a_l u + s_l u ((n^T r)_l - F_l), a_l = c_l + s_l F_l the apparent
// coefficient, F_l the calibration window's mean field in the test frame.) The temperature terms'
// own uncertainty (set_temperature_uncertainty) enters corrected_covariance at a given
// temperature: with y = n^T r, delta y_l = -u (delta a_l + (y_l - F_l) delta s_l) / (1 + s_l u),
// a_l and s_l taken as independent (the apparent coefficient is the well-determined combination;
// c_l and s_l alone are strongly anti-correlated, which the message does not carry).
#pragma once

#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"

#include <Eigen/Core>

#include <limits>
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

  /// Adds the temperature terms: reference_C (deg C), offset_per_C = c (unit of t per degC),
  /// scale_per_C = s (1/degC, not ppm). Throws std::invalid_argument unless all are finite.
  void set_temperature(double reference_C, const Eigen::Vector3d& offset_per_C, const Eigen::Vector3d& scale_per_C);
  bool has_temperature() const { return has_temperature_; }
  /// Standard errors of the apparent coefficients a (unit of t per degC) and of the scale
  /// coefficients s (1/degC; zero for the apparent model), and F, the calibration window's mean
  /// field in the test frame (unit of t), for corrected_covariance. Throws std::invalid_argument
  /// unless all are finite and the errors >= 0.
  void set_temperature_uncertainty(const Eigen::Vector3d& apparent_se_per_C, const Eigen::Vector3d& scale_se_per_C,
                                   const Eigen::Vector3d& mean_test_field);
  /// r = n^-T y, y_l = (t_l - d_l - c_l u) / (1 + s_l u), u = temperature_C - reference_C (see
  /// above); without temperature terms, correct(test). NaN components where 1 + s_l u <= 0 (a
  /// temperature tens of thousands of degC away: no physical reading).
  Eigen::Vector3d correct(const Eigen::Vector3d& test, double temperature_C) const;
  const Eigen::Vector3d& offset() const { return offset_; }

  /// Covariance of r (unit^2) from the covariance of t: n^-T C_t n^-1, plus, when
  /// include_calibration, the uncertainty of n itself propagated to first order:
  /// dr_j = -sum_ab (r - m)_a dn_ab (n^-1)_bj, i.e. J Cov(vec n) J^T with
  /// J_j,3a+b = -(r - m)_a (n^-1)_bj, m = anchor. (The offset's own noise terms, residual rms^2 / N
  /// and the trend's, are left out: they are small next to the test noise.) With temperature
  /// terms and a finite temperature_C (the temperature the reading was corrected at), also the
  /// terms' own uncertainty (see above): n^-T diag(var y) n^-1.
  Eigen::Matrix3d corrected_covariance(const Eigen::Matrix3d& test_covariance, const Eigen::Vector3d& corrected,
                                       bool include_calibration,
                                       double temperature_C = std::numeric_limits<double>::quiet_NaN()) const;

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
  bool has_temperature_ = false;
  double temperature_reference_C_ = 0.0;
  Eigen::Vector3d temperature_offset_ = Eigen::Vector3d::Zero();  ///< c, unit of t per degC
  Eigen::Vector3d temperature_scale_ = Eigen::Vector3d::Zero();   ///< s, 1/degC
  Eigen::Vector3d apparent_se_ = Eigen::Vector3d::Zero();         ///< of a, unit of t per degC
  Eigen::Vector3d scale_se_ = Eigen::Vector3d::Zero();            ///< of s, 1/degC
  Eigen::Vector3d mean_test_field_ = Eigen::Vector3d::Zero();     ///< F, unit of t
};

}  // namespace magnetometer_insitu_calibration
