// Do disjoint windows of one record agree within their intervals? With one n through the record
// and honest intervals, the windows' estimates scatter about a common value as their standard
// errors say (the paper's layout: K intervals, then the whole record).
//
// Per parameter p (scale ratios x, y, z; non-orthogonality xy, xz, yz; misalignment about x, y,
// z), with values v_k and standard errors s_k = ci95_k / 1.959964 of the K windows:
//   m = sum(v_k / s_k^2) / sum(1 / s_k^2)      (inverse-variance weighted mean)
//   chi2 = sum(((v_k - m) / s_k)^2)            (~ chi^2 with K - 1 dof when the windows agree)
//   birge_ratio = sqrt(chi2 / (K - 1))         (the factor the intervals would need to grow by to
//                                               hold the scatter; <= 1.3 with probability 0.83
//                                               for K = 4 when they are right)
// Jointly, over the nine entries of n with each window's 9x9 covariance C_k:
//   m = (sum C_k^-1)^-1 sum C_k^-1 vec(n_k),   chi2 = sum (vec(n_k) - m)^T C_k^-1 (vec(n_k) - m),
// 9 (K - 1) dof. Each window's covariance is itself estimated, from nu_k = covariance_dof
// cells (fd_wlse.hpp: as many as share its sandwich equally), so each window's term is
// Hotelling's T^2, not chi2: mean p nu / (nu - p - 1) over p entries (1.6 x chi2's for p = 9 at
// nu = 26, a simulated one-hour window's; 2 x at a real WIC hour's 20) and a heavier tail. Both
// statistics are referred to a chi2 scaled to the sum's mean and variance, each window
// contributing (K - 1) / K of its T^2's moments (Satterthwaite); for known covariances that is
// chi2 with K - 1 and 9 (K - 1) dof, as above.
// The Birge ratio is sqrt(chi2 / its mean).
// The windows disagree when the joint tail probability is below `significance`, or
// a parameter's is below significance / 9 (Bonferroni over the nine parameters): a false alarm
// rate of at most 2 x significance when n is constant and the intervals honest.
// The joint test needs each 9 x 9 covariance well estimated; from few cells its tail is heavier
// than T^2's while each parameter's alone is not: on simulated one-hour windows (18-27 cells)
// its false alarms were twice its level, from 36 cells at or under it (docs/estimator_validation.md
// B23-B25). So the joint test decides only when every window's covariance rests on
// kJointTestMinCells (four per entry of n) or more; below that the parameters decide one by one,
// and the text says so.
//
// A disagreement means that n is not one matrix through the record (a real change, or a relation
// that depends on the field's frequencies or directions, which change through a day) or that the
// windows' intervals are too narrow; either way the whole record's interval is then optimistic,
// by up to the largest Birge ratio. Windows whose quality is not ok are left out, and so are
// windows whose covariance rests on 4 cells or fewer (no reference distribution; the text says so).
#pragma once

#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"  // kJointTestMinCells

#include <array>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

struct ParameterAgreement {
  double weighted_mean = 0.0;  ///< the parameter's unit (ratio or degrees)
  double chi2 = 0.0;           ///< K - 1 degrees of freedom
  double expected_chi2 = 0.0;  ///< its mean when the windows agree: K - 1 for known covariances
  double birge_ratio = 0.0;    ///< sqrt(chi2 / expected_chi2)
  double p_value = 1.0;        ///< upper tail probability of chi2 (see the header)
};

struct WindowAgreement {
  bool assessed = false;  ///< false: fewer than two ok windows, or an unusable interval
  bool agree = true;      ///< meaningful when assessed
  int windows = 0;        ///< ok windows compared
  /// scale ratio x, y, z; non-orthogonality xy, xz, yz; misalignment x, y, z (kParameterNames).
  std::array<ParameterAgreement, 9> parameters{};
  double joint_chi2 = 0.0;  ///< NaN when a covariance is not positive definite
  int joint_dof = 0;
  double joint_expected_chi2 = 0.0;  ///< its mean when the windows agree: joint_dof for known covariances
  double joint_p_value = 1.0;
  bool joint_tested = false;  ///< the joint test decided: every covariance from >= kJointTestMinCells cells
  std::string text;  ///< one line: the verdict and the largest Birge ratio, or why not assessed

  static const std::array<const char*, 9> kParameterNames;  ///< "scale x", ..., "misalignment z"
  /// four cells per entry of n (sampling_distributions.hpp)
  static constexpr double kJointTestMinCells = magnetometer_insitu_calibration::kJointTestMinCells;
};

struct WindowAgreementSettings {
  double significance = 0.01;  ///< of the joint test, and x 1/9 of each parameter's

  void validate() const;  ///< throws InputError naming the field
};

/// Value and standard error (ci95 half-width / interval_quantile) of parameter k of a decomposition, in
/// WindowAgreement::kParameterNames order (0-2 scale ratios, 3-5 non-orthogonality deg, 6-8
/// misalignment deg).
struct ValueAndError {
  double value = 0.0, se = 0.0;
};
ValueAndError agreement_parameter(const CalibrationParameters& parameters, int k);

/// The agreement of `windows` (disjoint windows of one record; the caller leaves out the whole
/// record and overlapping windows). Windows whose quality is not ok are not compared.
WindowAgreement check_window_agreement(const std::vector<WindowEstimate>& windows,
                                       const WindowAgreementSettings& settings = {});

}  // namespace magnetometer_insitu_calibration
