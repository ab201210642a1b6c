// Do estimates of one n agree within their uncertainties? The one comparison behind the
// calibration change check (two windows, calibration_change.hpp) and the agreement of a record's
// disjoint windows (K windows, window_agreement.hpp), and the one table of the parameters every
// check and report names.
//
// Per parameter (kParameters: the scale ratios, non-orthogonalities and misalignments of
// decomposition.hpp), values v_k with standard errors s_k (ci95 / interval_quantile) whose
// variances are estimated from nu_k spectral cells (WindowEstimate::covariance_dof): Welch's test
// of equal means with unequal, estimated variances (Welch 1951, Biometrika 38, 330-336):
//   w_k = 1 / s_k^2,  W = sum w_k,  m = sum w_k v_k / W,  chi2 = sum w_k (v_k - m)^2,
//   h = sum (1 - w_k / W)^2 / nu_k,  c = 1 + 2 (K - 2) h / (K^2 - 1),
//   F = chi2 / ((K - 1) c)  ~  F(K - 1, (K^2 - 1) / (3 h)).
// For two estimates F is the square of Welch's t, z^2 with z = difference / combined standard
// error, and its denominator dof is Welch-Satterthwaite's; for known variances (every nu
// infinite) chi2 ~ chi^2(K - 1).
//
// Jointly over the nine entries of n, each window's 9 x 9 covariance C_k from nu_k cells:
//   chi2 = sum (vec n_k - m)^T C_k^-1 (vec n_k - m),  m the generalised least squares mean,
// 9 (K - 1) dof. Each window's term is Hotelling's T^2 rather than chi2 (its covariance is
// estimated): mean 9 nu / (nu - 10) and a heavier tail. chi2 is referred to a chi2 scaled to the
// sum's mean and variance, each window contributing (K - 1) / K of its T^2's moments
// (Satterthwaite); chi^2(9 (K - 1)) when every covariance is known.
//
// The rule, one for both checks: the estimates differ when a parameter's p-value is below
// alpha / 9 (Bonferroni over the nine), or the joint p-value below alpha where the joint test
// decides: when every covariance rests on kJointTestMinCells or more (below that its tail is
// heavier than the reference's while each parameter's alone holds). At most 2 alpha false alarms
// when n is one matrix and the intervals are honest.
// The measured false alarms of both checks are in docs/validation.md ("Window agreement and
// change check").
#pragma once

#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"

#include <array>
#include <vector>

namespace magnetometer_insitu_calibration {

/// One parameter of a decomposition, in the order every check, report and message uses.
struct ParameterInfo {
  const char* name;  ///< in words: "scale x", "nonorthogonality xy", "misalignment z"
  const char* key;   ///< in JSON and files: "scale_x", "nonorthogonality_xy", "misalignment_z"
  const char* unit;  ///< "" (a ratio) or "deg"
};
/// Scale ratios x, y, z; non-orthogonality xy, xz, yz; misalignment about x, y, z.
extern const std::array<ParameterInfo, 9> kParameters;

/// Value and standard error (ci95 / interval_quantile) of parameter k (kParameters order).
struct ValueAndError {
  double value = 0.0, se = 0.0;
};
ValueAndError parameter_value(const CalibrationParameters& parameters, int k);

/// Welch's test of one parameter over the estimates.
struct ParameterComparison {
  double weighted_mean = 0.0;  ///< the parameter's unit
  double chi2 = 0.0;           ///< sum w_k (v_k - m)^2, K - 1 degrees of freedom
  double expected_chi2 = 0.0;  ///< its mean when the estimates agree: K - 1 for known variances
  double birge_ratio = 0.0;    ///< sqrt(chi2 / expected_chi2): how much wider the intervals would need to be
  double p_value = 1.0;        ///< tail probability of Welch's F
};

struct EstimateComparison {
  bool assessed = false;  ///< false: fewer than two estimates, or an unusable standard error
  int estimates = 0;
  std::array<ParameterComparison, 9> parameters{};
  double joint_chi2 = 0.0;  ///< NaN when a covariance is not positive definite
  int joint_dof = 0;        ///< 9 (K - 1)
  double joint_expected_chi2 = 0.0;  ///< its mean when the estimates agree: joint_dof for known covariances
  double joint_p_value = 1.0;        ///< NaN when T^2's moments do not exist (12 cells or fewer)
  double fewest_cells = 0.0;         ///< the smallest covariance_dof of the estimates
  bool joint_tested = false;         ///< fewest_cells >= kJointTestMinCells: the joint test decides
  int least_likely = 0;              ///< the parameter with the smallest p_value
  std::string unusable;              ///< why not assessed ("" when assessed)

  /// The one rule: a parameter at alpha / 9, or the joint test at alpha where it decides.
  bool significant(double alpha) const;
  /// The smallest of the nine parameters' p-values.
  double smallest_parameter_p() const { return parameters[static_cast<std::size_t>(least_likely)].p_value; }
};

/// Compares estimates (their quality is the caller's to check; at least two for an assessment).
EstimateComparison compare_estimates(const std::vector<const WindowEstimate*>& estimates);

}  // namespace magnetometer_insitu_calibration
