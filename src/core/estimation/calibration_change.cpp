// Detection of a change of calibration: see calibration_change.hpp.
#include "magnetometer_insitu_calibration/estimation/calibration_change.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/estimation/window_agreement.hpp"  // agreement_parameter

#include <Eigen/Cholesky>

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
  Eigen::Matrix<double, 9, 1> d;
  for (int k = 0; k < 9; ++k) d(k) = latest.n(k / 3, k % 3) - accepted.n(k / 3, k % 3);
  const Matrix9d s = accepted.n_covariance + latest.n_covariance;
  const Eigen::LDLT<Matrix9d> ldlt(s);
  if (!d.allFinite() || !s.allFinite() || ldlt.info() != Eigen::Success || !ldlt.isPositive()) {
    out.text = "cannot compare: covariance not positive definite";
    return out;
  }
  out.chi2 = d.dot(ldlt.solve(d));
  out.covariance_dof = combined_covariance_dof(accepted.n_covariance, accepted.covariance_dof, latest.n_covariance,
                                               latest.covariance_dof);
  // NaN when the covariances rest on 9 cells or fewer: no joint test, the parameters decide.
  out.p_value = quadratic_form_tail_probability(out.chi2, 9, out.covariance_dof);
  const CalibrationParameters& a = accepted.parameters;
  const CalibrationParameters& b = latest.parameters;
  out.scale_difference = b.scale_ratio - a.scale_ratio;
  out.nonorthogonality_difference_deg = b.nonorthogonality_deg - a.nonorthogonality_deg;
  out.misalignment_difference_deg = b.misalignment_deg - a.misalignment_deg;
  // Per parameter, in WindowAgreement::kParameterNames order: z and the tail of F(1, nu).
  Eigen::Vector3d* zs[3] = {&out.scale_z, &out.nonorthogonality_z, &out.misalignment_z};
  const Eigen::Vector3d* ds[3] = {&out.scale_difference, &out.nonorthogonality_difference_deg,
                                  &out.misalignment_difference_deg};
  const char* names[9] = {"Kx",         "Ky",         "Kz",         "nonorth xy", "nonorth xz",
                          "nonorth yz", "misalign x", "misalign y", "misalign z"};
  int named = 0;
  bool parameter_testable = true;
  for (int k = 0; k < 9; ++k) {
    const ValueAndError pa = agreement_parameter(a, k), pb = agreement_parameter(b, k);
    const double variance = pa.se * pa.se + pb.se * pb.se;
    const double z = std::abs(pb.value - pa.value) / std::sqrt(std::max(variance, 1e-300));
    (*zs[k / 3])(k % 3) = z;
    const double nu = combined_variance_dof(pa.se * pa.se, accepted.covariance_dof, pb.se * pb.se,
                                            latest.covariance_dof);
    const double p = quadratic_form_tail_probability(z * z, 1, nu);
    parameter_testable &= std::isfinite(p);  // NaN when nu <= 1
    if (p < out.parameter_p_value) out.parameter_p_value = p, named = k;
  }
  if (!parameter_testable) {
    out.text = "cannot compare: a parameter's standard errors rest on too few spectral cells";
    return out;
  }
  out.joint_tested = std::min(accepted.covariance_dof, latest.covariance_dof) >= kJointTestMinCells;
  const double alpha = settings.false_alarm_probability;
  out.significant = out.joint_tested ? out.p_value < alpha : out.parameter_p_value < alpha / 9.0;
  const bool practical = out.scale_difference.cwiseAbs().maxCoeff() > settings.scale_tolerance ||
                         out.nonorthogonality_difference_deg.cwiseAbs().maxCoeff() > settings.angle_tolerance_deg ||
                         out.misalignment_difference_deg.cwiseAbs().maxCoeff() > settings.angle_tolerance_deg;
  out.status = out.significant && practical ? CalibrationChangeStatus::kChanged : CalibrationChangeStatus::kUnchanged;
  text << (out.status == CalibrationChangeStatus::kChanged ? "calibration changed" : "calibration unchanged")
       << ": chi2 " << out.chi2 << " (9 dof";
  if (std::isfinite(out.covariance_dof)) text << ", covariances from " << out.covariance_dof << " cells";
  text << ", p " << out.p_value;
  if (!out.joint_tested)
    text << "; not tested: a covariance from " << std::min(accepted.covariance_dof, latest.covariance_dof)
         << " cells, under " << kJointTestMinCells << "; the parameters one by one";
  text << "); largest move " << names[named] << " by " << (*ds[named / 3])(named % 3) << (named < 3 ? "" : " deg")
       << " (" << (*zs[named / 3])(named % 3) << " se, p " << out.parameter_p_value << ")";
  if (out.significant && !practical) text << ", significant but within the practical tolerances";
  out.text = text.str();
  return out;
}

}  // namespace magnetometer_insitu_calibration
