// Temperature of the test sensor as a regressor beside the reference, like the
// paper's trend column: the frequency-domain weighted least squares of Eq. 2 over the same band
// and weights, with two more columns per test component.
//
// Model (test frame, component l, nT; theta the test sensor's temperature in deg C, theta_ref
// the window's mean temperature, at which n is reported):
//   T_l = (R n)_l (1 + s_l (theta - theta_ref)) + c_l (theta - theta_ref) + d_l + trend_l tau
// s_l: scale coefficient (reported in ppm/degC), c_l: offset coefficient (nT/degC). Writing
// u = theta - theta_ref and R = mean(R) + dR, the regressors of component l are
//   [dR_x, dR_y, dR_z, tau, u, v_l],  v_l = u (dR n0)_l   (n0: a first estimate of n)
// and the fit gives a_l = c_l + s_l F_l on u (F_l = (mean(R) n0)_l, the mean field of the
// window in the test frame) and s_l on v_l. a_l, the "apparent" offset coefficient, is what a
// record constrains well; s_l is identified only through the product of temperature and field
// *variations* (tens of nT), so its interval is wide unless both vary together in the band, and
// c_l = a_l - s_l F_l inherits that width times F_l (tens of thousands of nT): separating scale
// from offset drift needs the field to change, as in a coil. Intervals: the frequency-domain
// sandwich of fd_wlse.cpp (each harmonic's own residual), t quantile of the 2M - p dof.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <Eigen/Core>

#include <string>

namespace magnetometer_insitu_calibration {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Matrix96d = Eigen::Matrix<double, 9, 6>;

struct TemperatureBand {
  double low_hz = 0.0002;   ///< band of the fit (use the window estimate's band)
  double high_hz = 0.01;
  double gamma = 1.0;       ///< weights lambda^gamma, as Eq. 2
  bool trend = true;        ///< the linear-trend column
  double min_range_C = 0.05;  ///< below this peak-to-peak temperature in the window: not fitted
};

struct TemperatureFit {
  bool fitted = false;
  std::string text;              ///< "fitted ...", or why not (the window then has no temperature terms)
  double reference_C = 0.0;      ///< theta_ref: the window's mean temperature, deg C
  double range_C = 0.0;          ///< max - min of the temperature in the window, deg C
  Eigen::Vector3d apparent_nT_per_C = Eigen::Vector3d::Zero();  ///< a_l = c_l + s_l F_l
  Eigen::Vector3d apparent_ci95_nT_per_C = Eigen::Vector3d::Zero();
  Eigen::Vector3d offset_nT_per_C = Eigen::Vector3d::Zero();    ///< c_l
  Eigen::Vector3d offset_ci95_nT_per_C = Eigen::Vector3d::Zero();
  Eigen::Vector3d scale_ppm_per_C = Eigen::Vector3d::Zero();    ///< s_l x 1e6
  Eigen::Vector3d scale_ci95_ppm_per_C = Eigen::Vector3d::Zero();
  Eigen::Vector3d mean_field_nT = Eigen::Vector3d::Zero();      ///< F_l, test frame
  /// Covariance of (a_0, s_0, a_1, s_1, a_2, s_2), s in 1/degC (not ppm).
  Matrix6d covariance = Matrix6d::Zero();
  /// d vec(n) (row-major, 9) / d (a_0, s_0, ..., s_2): how an error of the coefficients moves n
  /// when the fitted temperature terms are removed from T and n is estimated again (band
  /// weights lambda^gamma). Cov(n) gains coupling * covariance * coupling^T.
  Matrix96d coupling = Matrix96d::Zero();
  double dof = 0.0;              ///< 2M - p
};

/// Fits the temperature terms of one window (all inputs finite, same length; theta in deg C,
/// R and T in nT, sample period s). n0 from the window's estimate without temperature.
TemperatureFit fit_temperature(const Eigen::Ref<const Readings>& reference_nT, const Eigen::Ref<const Readings>& test_nT,
                               const Eigen::Ref<const Eigen::VectorXd>& temperature_C, double sample_period_s,
                               const Eigen::Matrix3d& n0, const TemperatureBand& band);

/// Refers the offset coefficients c_l = a_l - s_l F_l (and their intervals) to the mean field F
/// (nT, test frame) of the n that is published with them, F = (mean(R) n)^T: the model
/// T = (R n)(1 + s u) + c u + d that correction_node inverts takes its lever from that n. The fit
/// itself uses n0 (the estimate before the terms were removed); a and s do not depend on F, but
/// where s is barely determined (hundreds of ppm/degC on a few hours) a lever a few hundred nT off
/// moves c by tens of nT/degC and the full model's correction by s times that lever.
void refer_offset_to_mean_field(TemperatureFit& fit, const Eigen::Vector3d& mean_field_nT);

/// T with the fitted temperature terms removed: T_l - a_l u - s_l u (dR n0)_l (same n0).
Readings remove_temperature_terms(const Eigen::Ref<const Readings>& reference_nT, const Eigen::Ref<const Readings>& test_nT,
                                  const Eigen::Ref<const Eigen::VectorXd>& temperature_C, const Eigen::Matrix3d& n0,
                                  const TemperatureFit& fit);

}  // namespace magnetometer_insitu_calibration
