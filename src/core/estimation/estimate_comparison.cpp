// The comparison of estimates of one n: see estimate_comparison.hpp.
#include "magnetometer_insitu_calibration/estimation/estimate_comparison.hpp"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace magnetometer_insitu_calibration {

const std::array<ParameterInfo, 9> kParameters = {{
    {"scale x", "scale_x", ""},
    {"scale y", "scale_y", ""},
    {"scale z", "scale_z", ""},
    {"nonorthogonality xy", "nonorthogonality_xy", "deg"},
    {"nonorthogonality xz", "nonorthogonality_xz", "deg"},
    {"nonorthogonality yz", "nonorthogonality_yz", "deg"},
    {"misalignment x", "misalignment_x", "deg"},
    {"misalignment y", "misalignment_y", "deg"},
    {"misalignment z", "misalignment_z", "deg"},
}};

ValueAndError parameter_value(const CalibrationParameters& p, int k) {
  const double q = p.interval_quantile;  // ci95 half-width / standard error
  const int c = k % 3;
  if (k < 3) return {p.scale_ratio(c), p.scale_ratio_ci95(c) / q};
  if (k < 6) return {p.nonorthogonality_deg(c), p.nonorthogonality_ci95_deg(c) / q};
  return {p.misalignment_deg(c), p.misalignment_ci95_deg(c) / q};
}

bool EstimateComparison::significant(double alpha) const {
  if (!assessed) return false;
  return smallest_parameter_p() < alpha / 9.0 || (joint_tested && joint_p_value < alpha);
}

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Welch's test of parameter k over the estimates (estimate_comparison.hpp); false when a
/// standard error is unusable.
bool welch(const std::vector<const WindowEstimate*>& estimates, int k, ParameterComparison& out) {
  const double windows = static_cast<double>(estimates.size());
  double w_sum = 0.0, wv_sum = 0.0;
  std::vector<ValueAndError> p(estimates.size());
  for (std::size_t i = 0; i < estimates.size(); ++i) {
    p[i] = parameter_value(estimates[i]->parameters, k);
    if (!(p[i].se > 0.0) || !std::isfinite(p[i].se) || !std::isfinite(p[i].value)) return false;
    w_sum += 1.0 / (p[i].se * p[i].se);
    wv_sum += p[i].value / (p[i].se * p[i].se);
  }
  out.weighted_mean = wv_sum / w_sum;
  double h = 0.0;
  out.chi2 = 0.0;
  for (std::size_t i = 0; i < estimates.size(); ++i) {
    const double w = 1.0 / (p[i].se * p[i].se);
    out.chi2 += w * (p[i].value - out.weighted_mean) * (p[i].value - out.weighted_mean);
    h += (1.0 - w / w_sum) * (1.0 - w / w_sum) / estimates[i]->covariance_dof;  // 0 for a known variance
  }
  const double scale = 1.0 + 2.0 * (windows - 2.0) * h / (windows * windows - 1.0);
  const double d1 = windows - 1.0, d2 = h > 0.0 ? (windows * windows - 1.0) / (3.0 * h) : kNaN;
  if (h > 0.0) {
    out.p_value = f_tail_probability(out.chi2 / (d1 * scale), d1, d2);
    out.expected_chi2 = d1 * scale * (d2 > 2.0 ? d2 / (d2 - 2.0) : 1.0);
  } else {
    out.p_value = chi2_tail_probability(out.chi2, d1);
    out.expected_chi2 = d1;
  }
  out.birge_ratio = std::sqrt(out.chi2 / out.expected_chi2);
  return true;
}

/// The joint chi2 of vec(n) about its generalised least squares mean; NaN when a covariance is
/// not positive definite.
double joint_chi2(const std::vector<const WindowEstimate*>& estimates) {
  using Vector9d = Eigen::Matrix<double, 9, 1>;
  std::vector<Matrix9d> inverses;
  Matrix9d information = Matrix9d::Zero();
  Vector9d weighted = Vector9d::Zero();
  std::vector<Vector9d> values;
  for (const WindowEstimate* w : estimates) {
    const Eigen::LDLT<Matrix9d> ldlt(w->n_covariance);
    if (!w->n_covariance.allFinite() || ldlt.info() != Eigen::Success || !ldlt.isPositive() ||
        !(ldlt.vectorD().minCoeff() > 0.0)) {
      return kNaN;
    }
    Vector9d v;
    for (int k = 0; k < 9; ++k) v(k) = w->n(k / 3, k % 3);
    inverses.push_back(ldlt.solve(Matrix9d::Identity()));
    information += inverses.back();
    weighted += inverses.back() * v;
    values.push_back(v);
  }
  const Vector9d mean = information.ldlt().solve(weighted);
  double chi2 = 0.0;
  for (std::size_t i = 0; i < values.size(); ++i) chi2 += (values[i] - mean).dot(inverses[i] * (values[i] - mean));
  return chi2;
}

}  // namespace

EstimateComparison compare_estimates(const std::vector<const WindowEstimate*>& estimates) {
  EstimateComparison out;
  out.estimates = static_cast<int>(estimates.size());
  if (estimates.size() < 2) {
    out.unusable = "fewer than two estimates";
    return out;
  }
  for (int k = 0; k < 9; ++k) {
    if (!welch(estimates, k, out.parameters[static_cast<std::size_t>(k)])) {
      out.unusable = std::string("no usable interval for ") + kParameters[static_cast<std::size_t>(k)].name;
      return out;
    }
    if (out.parameters[static_cast<std::size_t>(k)].p_value < out.parameters[static_cast<std::size_t>(out.least_likely)].p_value)
      out.least_likely = k;
  }
  out.assessed = true;
  // Jointly: each estimate's share (K - 1) / K of its Hotelling T^2's moments, summed, and a chi2
  // scaled to that mean and variance (Satterthwaite).
  const double share = static_cast<double>(estimates.size() - 1) / static_cast<double>(estimates.size());
  double mean = 0.0, variance = 0.0;
  out.fewest_cells = std::numeric_limits<double>::infinity();
  for (const WindowEstimate* w : estimates) {
    const QuadraticFormMoments m = quadratic_form_moments(w->covariance_dof, 9);
    mean += share * m.mean;
    variance += share * m.variance;
    out.fewest_cells = std::min(out.fewest_cells, w->covariance_dof);
  }
  out.joint_dof = 9 * (out.estimates - 1);
  out.joint_chi2 = joint_chi2(estimates);
  out.joint_expected_chi2 = mean;
  out.joint_p_value = std::isfinite(out.joint_chi2) && mean > 0.0 && variance > 0.0
                          ? chi2_tail_probability(out.joint_chi2 * 2.0 * mean / variance, 2.0 * mean * mean / variance)
                          : kNaN;
  out.joint_tested = out.fewest_cells >= kJointTestMinCells;
  return out;
}

}  // namespace magnetometer_insitu_calibration
