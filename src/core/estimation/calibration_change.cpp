// Detection of a change of calibration: see calibration_change.hpp.
#include "magnetometer_insitu_calibration/estimation/calibration_change.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <Eigen/Cholesky>

#include <cmath>
#include <limits>
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

double chi2_tail_probability(double x, double dof) {
  if (!(x > 0.0)) return 1.0;
  const double a = 0.5 * dof, z = 0.5 * x;
  const double log_prefactor = a * std::log(z) - z - std::lgamma(a);
  if (z < a + 1.0) {  // series for P(a, z), then Q = 1 - P
    double term = 1.0 / a, sum = term;
    for (int k = 1; k < 500; ++k) {
      term *= z / (a + k);
      sum += term;
      if (term < sum * 1e-15) break;
    }
    return std::max(0.0, 1.0 - sum * std::exp(log_prefactor));
  }
  // Continued fraction for Q(a, z) (modified Lentz).
  double b = z + 1.0 - a, c = 1.0 / 1e-300, d = 1.0 / b, h = d;
  for (int i = 1; i < 500; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < 1e-300) d = 1e-300;
    c = b + an / c;
    if (std::abs(c) < 1e-300) c = 1e-300;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < 1e-15) break;
  }
  return std::exp(log_prefactor) * h;
}

namespace {

/// Continued fraction of the regularised incomplete beta function (modified Lentz): I_x(a, b) =
/// x^a (1 - x)^b / (a B(a, b)) / (1 + d1 / (1 + d2 / (1 + ...))), d_2m+1 = -(a + m)(a + b + m) x /
/// ((a + 2m)(a + 2m + 1)), d_2m = m (b - m) x / ((a + 2m - 1)(a + 2m)); converges fast for
/// x < (a + 1) / (a + b + 2).
double beta_continued_fraction(double a, double b, double x) {
  constexpr double kTiny = 1e-300;
  double c = 1.0, d = 1.0 - (a + b) * x / (a + 1.0);
  if (std::abs(d) < kTiny) d = kTiny;
  d = 1.0 / d;
  double h = d;
  for (int m = 1; m < 1000; ++m) {
    const double even = m * (b - m) * x / ((a + 2.0 * m - 1.0) * (a + 2.0 * m));
    const double odd = -(a + m) * (a + b + m) * x / ((a + 2.0 * m) * (a + 2.0 * m + 1.0));
    for (double step : {even, odd}) {
      d = 1.0 + step * d;
      if (std::abs(d) < kTiny) d = kTiny;
      c = 1.0 + step / c;
      if (std::abs(c) < kTiny) c = kTiny;
      d = 1.0 / d;
      h *= d * c;
    }
    if (std::abs(d * c - 1.0) < 1e-15) break;
  }
  return h;
}

/// Regularised incomplete beta function I_x(a, b), a, b > 0.
double incomplete_beta(double x, double a, double b) {
  if (!(x > 0.0)) return 0.0;
  if (!(x < 1.0)) return 1.0;
  const double log_front = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
  if (x < (a + 1.0) / (a + b + 2.0)) return std::exp(log_front) * beta_continued_fraction(a, b, x) / a;
  return 1.0 - std::exp(log_front) * beta_continued_fraction(b, a, 1.0 - x) / b;
}

}  // namespace

double f_tail_probability(double f, double d1, double d2) {
  if (!(f > 0.0)) return 1.0;
  return incomplete_beta(d2 / (d2 + d1 * f), 0.5 * d2, 0.5 * d1);
}

double quadratic_form_tail_probability(double q, int p, double nu) {
  if (!std::isfinite(nu)) return chi2_tail_probability(q, p);
  if (!(nu > p)) return std::numeric_limits<double>::quiet_NaN();
  const double d2 = nu - p + 1.0;
  return f_tail_probability(q * d2 / (p * nu), p, d2);
}

double combined_covariance_dof(const Matrix9d& first, double first_dof, const Matrix9d& second, double second_dof) {
  const double t1 = first.trace(), t2 = second.trace();
  const double spread = (std::isfinite(first_dof) ? t1 * t1 / first_dof : 0.0) +
                        (std::isfinite(second_dof) ? t2 * t2 / second_dof : 0.0);
  if (!(spread > 0.0)) return std::numeric_limits<double>::infinity();
  return (t1 + t2) * (t1 + t2) / spread;
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
