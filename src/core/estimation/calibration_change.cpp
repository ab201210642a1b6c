// Detection of a change of calibration: see calibration_change.hpp.
#include "magnetometer_insitu_calibration/estimation/calibration_change.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace magnetometer_insitu_calibration {

void CalibrationChangeSettings::validate() const {
  if (!(false_alarm_probability > 0.0 && false_alarm_probability < 0.5))
    throw InputError("false_alarm_probability", "must be in (0, 0.5)");
  if (!(scale_tolerance >= 0.0) || !std::isfinite(scale_tolerance)) throw InputError("scale_tolerance", "must be >= 0");
  if (!(angle_tolerance_deg >= 0.0) || !std::isfinite(angle_tolerance_deg))
    throw InputError("angle_tolerance_deg", "must be >= 0 degrees");
}

const char* calibration_change_status_name(CalibrationChangeStatus status) {
  switch (status) {
    case CalibrationChangeStatus::kUnchanged: return "unchanged";
    case CalibrationChangeStatus::kChanged: return "changed";
    case CalibrationChangeStatus::kInconclusive: return "inconclusive";
  }
  return "unknown";
}

CalibrationChange check_calibration_change(const WindowEstimate& accepted, const WindowEstimate& latest,
                                           const CalibrationChangeSettings& settings) {
  settings.validate();
  CalibrationChange out;
  std::ostringstream text;
  if (accepted.quality != Quality::kOk || latest.quality != Quality::kOk) {
    text << "cannot compare: accepted window is " << quality_name(accepted.quality) << ", latest is "
         << quality_name(latest.quality);
    out.text = text.str();
    return out;
  }
  const EstimateComparison c = compare_estimates({&accepted, &latest});
  if (!c.assessed) {
    out.text = "cannot compare: " + c.unusable;
    return out;
  }
  if (!std::isfinite(c.joint_chi2)) {
    out.text = "cannot compare: covariance not positive definite";
    return out;
  }
  for (std::size_t k = 0; k < 9; ++k) {
    if (!std::isfinite(c.parameters[k].p_value)) {
      out.text = "cannot compare: a parameter's standard errors rest on too few spectral cells";
      return out;
    }
  }
  out.chi2 = c.joint_chi2;
  out.covariance_dof = c.fewest_cells;
  out.p_value = c.joint_p_value;
  out.joint_tested = c.joint_tested;
  out.parameter_p_value = c.smallest_parameter_p();
  out.significant = c.significant(settings.false_alarm_probability);
  const CalibrationParameters& a = accepted.parameters;
  const CalibrationParameters& b = latest.parameters;
  out.scale_difference = b.scale_ratio - a.scale_ratio;
  out.nonorthogonality_difference_deg = b.nonorthogonality_deg - a.nonorthogonality_deg;
  out.misalignment_difference_deg = b.misalignment_deg - a.misalignment_deg;
  // Per parameter, in kParameters order: |difference| / combined standard error (for two
  // estimates Welch's chi2 is its square).
  Eigen::Vector3d* zs[3] = {&out.scale_z, &out.nonorthogonality_z, &out.misalignment_z};
  const Eigen::Vector3d* ds[3] = {&out.scale_difference, &out.nonorthogonality_difference_deg,
                                  &out.misalignment_difference_deg};
  for (int k = 0; k < 9; ++k) (*zs[k / 3])(k % 3) = std::sqrt(c.parameters[static_cast<std::size_t>(k)].chi2);
  const bool practical = out.scale_difference.cwiseAbs().maxCoeff() > settings.scale_tolerance ||
                         out.nonorthogonality_difference_deg.cwiseAbs().maxCoeff() > settings.angle_tolerance_deg ||
                         out.misalignment_difference_deg.cwiseAbs().maxCoeff() > settings.angle_tolerance_deg;
  out.status = out.significant && practical ? CalibrationChangeStatus::kChanged : CalibrationChangeStatus::kUnchanged;
  const int named = c.least_likely;
  text << (out.status == CalibrationChangeStatus::kChanged ? "calibration changed" : "calibration unchanged")
       << ": chi2 " << out.chi2 << " (9 dof";
  if (std::isfinite(out.covariance_dof)) text << ", covariances from " << out.covariance_dof << " cells";
  text << ", p " << out.p_value;
  if (!out.joint_tested)
    text << "; not tested: a covariance from " << out.covariance_dof << " cells, under " << kJointTestMinCells
         << "; the parameters one by one";
  text << "); largest move " << kParameters[static_cast<std::size_t>(named)].name << " by " << (*ds[named / 3])(named % 3)
       << (named < 3 ? "" : " deg") << " (" << (*zs[named / 3])(named % 3) << " se, p " << out.parameter_p_value << ")";
  if (out.significant && !practical) text << ", significant but within the practical tolerances";
  out.text = text.str();
  return out;
}

}  // namespace magnetometer_insitu_calibration
