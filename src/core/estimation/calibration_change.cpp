// Detection of a change of calibration: see calibration_change.hpp.
#include "magnetometer_insitu_calibration/estimation/calibration_change.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <Eigen/Cholesky>

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
  out.p_value = quadratic_form_tail_probability(out.chi2, 9, out.covariance_dof);
  if (!std::isfinite(out.p_value)) {
    text << "cannot compare: the covariances rest on " << out.covariance_dof
         << " spectral cells, too few for a joint test of 9 entries";
    out.text = text.str();
    return out;
  }
  const CalibrationParameters& a = accepted.parameters;
  const CalibrationParameters& b = latest.parameters;
  constexpr double kZ95 = 1.959964;
  auto z_of = [&](const Eigen::Vector3d& diff, const Eigen::Vector3d& ci_a, const Eigen::Vector3d& ci_b) {
    const Eigen::Vector3d se = ((ci_a / kZ95).cwiseAbs2() + (ci_b / kZ95).cwiseAbs2()).cwiseSqrt();
    return Eigen::Vector3d(diff.cwiseAbs().cwiseQuotient(se.cwiseMax(1e-300)));
  };
  out.scale_difference = b.scale_ratio - a.scale_ratio;
  out.nonorthogonality_difference_deg = b.nonorthogonality_deg - a.nonorthogonality_deg;
  out.misalignment_difference_deg = b.misalignment_deg - a.misalignment_deg;
  out.scale_z = z_of(out.scale_difference, a.scale_ratio_ci95, b.scale_ratio_ci95);
  out.nonorthogonality_z = z_of(out.nonorthogonality_difference_deg, a.nonorthogonality_ci95_deg, b.nonorthogonality_ci95_deg);
  out.misalignment_z = z_of(out.misalignment_difference_deg, a.misalignment_ci95_deg, b.misalignment_ci95_deg);
  const bool significant = out.p_value < settings.false_alarm_probability;
  const bool practical = out.scale_difference.cwiseAbs().maxCoeff() > settings.scale_tolerance ||
                         out.nonorthogonality_difference_deg.cwiseAbs().maxCoeff() > settings.angle_tolerance_deg ||
                         out.misalignment_difference_deg.cwiseAbs().maxCoeff() > settings.angle_tolerance_deg;
  out.status = significant && practical ? CalibrationChangeStatus::kChanged : CalibrationChangeStatus::kUnchanged;
  // Name the parameter that moved most (in standard errors).
  const char* names[3][3] = {{"Kx", "Ky", "Kz"}, {"nonorth xy", "nonorth xz", "nonorth yz"}, {"misalign x", "misalign y", "misalign z"}};
  const Eigen::Vector3d* zs[3] = {&out.scale_z, &out.nonorthogonality_z, &out.misalignment_z};
  const Eigen::Vector3d* ds[3] = {&out.scale_difference, &out.nonorthogonality_difference_deg, &out.misalignment_difference_deg};
  int gi = 0, ci = 0;
  for (int g = 0; g < 3; ++g)
    for (int c = 0; c < 3; ++c)
      if ((*zs[g])(c) > (*zs[gi])(ci)) gi = g, ci = c;
  text << (out.status == CalibrationChangeStatus::kChanged ? "calibration changed" : "calibration unchanged")
       << ": chi2 " << out.chi2 << " (9 dof";
  if (std::isfinite(out.covariance_dof)) text << ", covariances from " << out.covariance_dof << " cells";
  text << ", p " << out.p_value << "); largest move " << names[gi][ci] << " by "
       << (*ds[gi])(ci) << (gi == 0 ? "" : " deg") << " (" << (*zs[gi])(ci) << " se)";
  if (significant && !practical) text << ", significant but within the practical tolerances";
  out.text = text.str();
  return out;
}

}  // namespace magnetometer_insitu_calibration
