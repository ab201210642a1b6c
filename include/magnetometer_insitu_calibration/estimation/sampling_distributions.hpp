// Sampling distributions of the package's comparison of estimates (estimate_comparison.hpp) and
// of its intervals (decomposition.hpp): chi2 and F tails, Student's t quantile, and the moments of
// Hotelling's T^2, the law of a quadratic form in a covariance that is itself estimated from a
// finite number of spectral cells (WindowEstimate::covariance_dof).
#pragma once

#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"  // Matrix9d

namespace magnetometer_insitu_calibration {

/// Upper tail probability of Fisher's F distribution with (d1, d2) degrees of freedom at f
/// (regularised incomplete beta function I_{d2 / (d2 + d1 f)}(d2 / 2, d1 / 2)).
double f_tail_probability(double f, double d1, double d2);

/// Mean and variance of q = d^T S^-1 d over p entries, S estimated with nu degrees of freedom and
/// d of covariance E[S]: Hotelling's T^2 = a F(p, d2), a = p nu / d2, d2 = nu - p + 1, so the mean
/// is p nu / (nu - p - 1); chi2's p and 2p when nu is infinite; NaN when the variance does not
/// exist (nu <= p + 3).
struct QuadraticFormMoments {
  double mean = 0.0, variance = 0.0;
};
QuadraticFormMoments quadratic_form_moments(double nu, int p);

/// The joint test over the nine entries of n (estimate_comparison.hpp) decides only when every
/// window's covariance rests on at least this many cells (covariance_dof, four per entry of n):
/// on simulated records of one n its false alarms were twice its level from one-hour windows'
/// 18-27 cells and at or under it from 36 (two- and three-hour windows; docs/validation.md).
/// Below, the nine parameters decide one by one (Bonferroni), whose tests hold from fewer cells.
constexpr double kJointTestMinCells = 36.0;

/// Two-sided quantile of Student's t with nu (> 0, not necessarily whole) degrees of freedom: the
/// x with P(|t_nu| > x) = tail, e.g. 2.064 for tail 0.05 and nu = 24, 1.960 (the normal's) for an
/// infinite nu; NaN for nu <= 0 or a tail outside (0, 1). A 95 % interval from a standard error
/// whose variance is estimated from nu spectral cells is +- x(0.05, nu) standard errors
/// (decomposition.hpp, WindowEstimate::covariance_dof).
double student_t_two_sided_quantile(double tail, double nu);

/// Upper tail probability of the chi^2 distribution with `dof` (> 0, not necessarily whole)
/// degrees of freedom at x (regularised incomplete gamma function Q(dof/2, x/2)).
double chi2_tail_probability(double x, double dof);

}  // namespace magnetometer_insitu_calibration
