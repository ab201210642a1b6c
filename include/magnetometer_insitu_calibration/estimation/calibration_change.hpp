// Has the calibration changed? Compares a new window's estimate (e.g. the latest sliding window)
// with the accepted calibration, accounting for the uncertainty of both: the package's one
// comparison of estimates (estimate_comparison.hpp) for two windows, taken as independent (a
// sliding window that overlaps the accepted one makes the test conservative). Per parameter its
// statistic is z^2 = difference^2 / (se_new^2 + se_accepted^2), Welch's t for two estimated
// variances (p from F(1, nu), nu by Welch-Satterthwaite); jointly d^T (C_new + C_accepted)^-1 d
// over vec(n), referred to the two windows' Hotelling T^2 moments. Significant by the comparison's
// rule at false_alarm_probability. A change is reported only when it is significant AND some
// parameter moved by more than its practical tolerance (scale_tolerance, angle_tolerance_deg): very
// long windows make tiny, harmless changes significant. Measured false alarms between windows of
// one n: docs/validation.md ("Window agreement and change check").
//
// ROS use (calibration node, diagnostic_updater): keep the accepted WindowEstimate; for every
// new window call
//   const CalibrationChange c = check_calibration_change(accepted, latest, settings);
//   if (c.status == CalibrationChangeStatus::kChanged) stat.summary(WARN, c.text);
// and add c.chi2, c.p_value, c.joint_tested, c.parameter_p_value and the per-parameter z values
// as key/value pairs.
#pragma once

#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/estimation/estimate_comparison.hpp"

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
  double covariance_dof = 0.0;  ///< the fewer cells of the two covariances (infinite: both known)
  double p_value = 1.0;  ///< its tail probability (estimate_comparison.hpp)
  bool joint_tested = false;  ///< the joint test decides: both covariances from >= kJointTestMinCells cells
  double parameter_p_value = 1.0;  ///< the smallest of the nine parameters' tail probabilities (F(1, nu))
  bool significant = false;  ///< the comparison's rule at false_alarm_probability
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
