// Has the calibration changed? Compares a new window's estimate (e.g. the latest sliding window)
// with the accepted calibration, accounting for the uncertainty of both.
//
// Rule. d = vec(n_new) - vec(n_accepted) (row-major, 9 entries), with covariance
// S = Cov_new + Cov_accepted (the two windows taken as independent; a sliding window that
// overlaps the accepted one makes the test conservative). The joint statistic
//   chi2 = d^T S^-1 d          (~ chi^2 with 9 degrees of freedom when nothing changed)
// is significant when its tail probability is below false_alarm_probability. The covariances are
// themselves estimated, each from WindowEstimate::covariance_dof spectral cells: chi2 is then
// Hotelling's T^2, whose tail is F's, (nu - 8) / (9 nu) chi2 ~ F(9, nu - 8), with nu of the sum
// S from the two windows' by Satterthwaite's rule on the traces (nu: the cells each covariance
// rests on, fd_wlse.hpp). Consecutive one-hour windows of one n: chi2's tail called 1.30 % of
// 2300 pairs changed at 1e-3, F's with the band's 36 cells 0.26 % (docs/estimator_validation.md
// B23), the rule below 0.10 % of 6900 (B25); a known covariance (nu infinite) gives chi2's tail.
// Per parameter (scale-factor ratios, non-orthogonality, misalignment)
//   z = |difference| / sqrt(se_new^2 + se_accepted^2),   p = P(F(1, nu) > z^2)
// with nu of the two standard errors by Welch-Satterthwaite (Student's t for an estimated
// variance). The joint test decides only when both windows' covariances rest on
// kJointTestMinCells (36) cells or more (sampling_distributions.hpp); below that (one-hour
// windows, and hours dominated by a few harmonics) the joint statistic's tail is heavier than
// T^2's and the
// nine parameters decide one by one, each at false_alarm_probability / 9 (Bonferroni), as the
// report's agreement check does (B24, B25). A change is reported only when it is significant AND
// some parameter moved by more than its practical tolerance (scale_tolerance, angle_tolerance_deg):
// very long windows make tiny, harmless changes significant.
//
// ROS use (calibration node, diagnostic_updater): keep the accepted WindowEstimate; for every
// new window call
//   const CalibrationChange c = check_calibration_change(accepted, latest, settings);
//   if (c.status == CalibrationChangeStatus::kChanged) stat.summary(WARN, c.text);
//   else if (c.status == CalibrationChangeStatus::kInconclusive) stat.summary(OK, c.text);
// and add c.chi2, c.p_value, c.joint_tested, c.parameter_p_value and the per-parameter z values
// as key/value pairs.
#pragma once

#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"  // chi2 and F tails

#include <Eigen/Core>

#include <string>

namespace magnetometer_insitu_calibration {

struct CalibrationChangeSettings {
  double false_alarm_probability = 1e-3;  ///< of the joint chi^2 test when nothing changed
  double scale_tolerance = 1e-4;          ///< practical tolerance of a scale-factor ratio (0.01 %)
  double angle_tolerance_deg = 0.005;     ///< practical tolerance of an angle, degrees

  void validate() const;  ///< throws InputError naming the field
};

enum class CalibrationChangeStatus : int {
  kUnchanged = 0,
  kChanged = 1,
  kInconclusive = 2,  ///< a window is not Quality::kOk or its covariance is unusable
};
const char* calibration_change_status_name(CalibrationChangeStatus status);  ///< "unchanged", ...

struct CalibrationChange {
  CalibrationChangeStatus status = CalibrationChangeStatus::kInconclusive;
  double chi2 = 0.0;     ///< joint statistic, 9 degrees of freedom
  double covariance_dof = 0.0;  ///< cells behind S = Cov_new + Cov_accepted (infinite: known)
  double p_value = 1.0;  ///< its tail probability (F's for an estimated S, chi2's for a known one)
  bool joint_tested = false;  ///< the joint test decided: both covariances from >= kJointTestMinCells cells
  double parameter_p_value = 1.0;  ///< the smallest of the nine parameters' tail probabilities (F(1, nu))
  bool significant = false;  ///< joint_tested ? p_value : 9 x parameter_p_value, below false_alarm_probability
  /// |difference| / combined standard error per parameter (x, y, z or xy, xz, yz).
  Eigen::Vector3d scale_z = Eigen::Vector3d::Zero(), nonorthogonality_z = Eigen::Vector3d::Zero(),
                  misalignment_z = Eigen::Vector3d::Zero();
  Eigen::Vector3d scale_difference = Eigen::Vector3d::Zero();        ///< new - accepted
  Eigen::Vector3d nonorthogonality_difference_deg = Eigen::Vector3d::Zero();
  Eigen::Vector3d misalignment_difference_deg = Eigen::Vector3d::Zero();
  std::string text;  ///< one line for the diagnostic message
};

CalibrationChange check_calibration_change(const WindowEstimate& accepted, const WindowEstimate& latest,
                                           const CalibrationChangeSettings& settings = {});

}  // namespace magnetometer_insitu_calibration
