// Do disjoint windows of one record agree within their intervals? With one n through the record
// and honest intervals, the windows' estimates scatter about a common value as their standard
// errors say (the paper's layout: K intervals, then the whole record). The test is the package's
// one comparison of estimates (estimate_comparison.hpp: Welch's test per parameter, the joint
// chi2 over vec(n), the rule between them) at `significance`: a false alarm rate of at most
// 2 x significance when n is constant and the intervals honest.
//
// A disagreement means that n is not one matrix through the record (a real change, or a relation
// that depends on the field's frequencies or directions, which change through a day) or that the
// windows' intervals are too narrow; either way the whole record's interval is then optimistic,
// by up to the largest Birge ratio sqrt(chi2 / expected). Windows whose quality is not ok are
// left out, and so are windows whose covariance rests on 4 cells or fewer (no reference
// distribution; the text says so).
#pragma once

#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/estimation/estimate_comparison.hpp"

#include <array>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// One parameter's test (Welch's): weighted mean, chi2, its expected value, Birge ratio, p.
using ParameterAgreement = ParameterComparison;

struct WindowAgreement {
  bool assessed = false;  ///< false: fewer than two ok windows, or an unusable interval
  bool agree = true;      ///< meaningful when assessed
  int windows = 0;        ///< ok windows compared
  std::array<ParameterAgreement, 9> parameters{};  ///< kParameters order
  double joint_chi2 = 0.0;  ///< NaN when a covariance is not positive definite
  int joint_dof = 0;
  double joint_expected_chi2 = 0.0;  ///< its mean when the windows agree: joint_dof for known covariances
  double joint_p_value = 1.0;
  bool joint_tested = false;  ///< the joint test decided: every covariance from >= kJointTestMinCells cells
  std::string text;  ///< one line: the verdict and the largest Birge ratio, or why not assessed
};

struct WindowAgreementSettings {
  double significance = 0.01;  ///< of the joint test, and x 1/9 of each parameter's

  void validate() const;  ///< throws InputError naming the field
};

/// The agreement of `windows` (disjoint windows of one record; the caller leaves out the whole
/// record and overlapping windows). Windows whose quality is not ok are not compared.
WindowAgreement check_window_agreement(const std::vector<WindowEstimate>& windows,
                                       const WindowAgreementSettings& settings = {});

}  // namespace magnetometer_insitu_calibration
