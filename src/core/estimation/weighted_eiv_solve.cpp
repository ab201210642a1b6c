// Weighted normal equations of the robust estimator over its cells, and their solution with or
// without the errors-in-variables correction (robust_estimator.hpp, steps 3 and 5; the
// correction itself: errors_in_variables.hpp).
#include "robust_sections.hpp"

#include "magnetometer_insitu_calibration/estimation/errors_in_variables.hpp"

#include <Eigen/LU>

#include <cmath>

namespace magnetometer_insitu_calibration::detail::robust {

/// Ratio mode: E|X_noise,c|^2 of the reference at cell c, estimated from the cell's own residual
/// power (share x capped |e|^2, see kNoiseCap). Per cell rather than one level per bin: the
/// noise PSD changes inside a bin (1/f) while the weights g = lambda^gamma rise across it, so a
/// bin-constant level misweights it; and the capped mean has half the variance of the median
/// (relative variance 1/n against 1/(n ln^2 2) = 2.08/n for exponential |e|^2), which matters
/// because (A - N)^-1 is convex in N: a noisier N is a biased (over-) correction.
Eigen::Vector3d ratio_noise_power(const Eigen::Vector3d& e2, const Eigen::Vector3d& scale2, double share) {
  static const double kappa = 1.0 - std::exp(-kNoiseCap);
  return (share / kappa) * e2.cwiseMin(kNoiseCap * scale2);
}

NormalEquations weighted_normal_equations(const std::vector<Cell>& cells, const std::vector<double>& weight,
                                          const RobustSettings& rs, double sample_period_s, int exclude) {
  NormalEquations out;
  NoiseSpectrum given;
  given.white_nT = rs.reference_white_nT;
  given.pink_nT_per_sqrt_hz = rs.reference_pink_nT_per_sqrt_hz;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const Cell& cell = cells[i];
    const double wg = weight[i] * cell.g;
    if (wg == 0.0 || cell.section == exclude) continue;
    out.a.noalias() += wg * (cell.x * cell.x.adjoint()).real();
    out.c.noalias() += wg * (cell.x * cell.y.adjoint()).real();
    if (rs.eiv == EivCorrection::kGiven) {
      out.given_noise.diagonal() += wg * given.expected_periodogram(cell.frequency_hz, sample_period_s, cell.length);
    }
  }
  return out;
}

namespace {

/// n = (A - N)^-1 C from the weighted sums and the inverse of A - N (N = 0: Eq. 2 itself, n in
/// test nT per reference nT); false when A - N is singular (errors_in_variables.hpp).
bool solve_corrected(const NormalEquations& sums, const Eigen::Matrix3d& noise, Eigen::Matrix3d& n,
                     Eigen::Matrix3d& a_inverse) {
  Eigen::MatrixXd solution, inverse;
  const Eigen::MatrixXd a_dyn = sums.a, c_dyn = sums.c;
  if (!corrected_solve(a_dyn, noise, c_dyn, solution, &inverse)) return false;
  n = solution;
  a_inverse = inverse;
  return true;
}

}  // namespace

WeightedSolution solve_weighted(const NormalEquations& sums, const Eigen::Matrix3d& noise) {
  WeightedSolution out;
  if (!solve_corrected(sums, Eigen::Matrix3d::Zero(), out.n_uncorrected, out.a_inverse_uncorrected)) return out;
  out.ok = true;
  out.a = sums.a;
  out.n = out.n_uncorrected;
  out.a_inverse = out.a_inverse_uncorrected;
  Eigen::Matrix3d corrected, corrected_inverse;
  if (noise.diagonal().sum() > 0.0 && solve_corrected(sums, noise, corrected, corrected_inverse)) {
    out.n = corrected;
    out.a_inverse = corrected_inverse;
    out.noise = noise;
    out.eiv_applied = true;
  }
  return out;
}

/// n for frozen cell weights: the last step of the IRLS, and each delete-one-section refit of
/// the jackknife (exclude = that section; -1 for none). Ratio mode iterates the fixed point
/// n = (A - N(n))^-1 C, N(n) = sum w g ratio_noise_power(|e(n)|^2), to convergence from
/// n_start; given mode subtracts its known N; none solves Eq. 2 with the weights.
WeightedSolution solve_frozen(const std::vector<Cell>& cells, const std::vector<double>& weight,
                              const std::vector<Eigen::Vector3d>& scale2, const RobustSettings& rs,
                              double sample_period_s, int exclude, const Eigen::Matrix3d& n_start) {
  const double share = reference_share_of_residual(rs.eiv_noise_ratio);
  const NormalEquations sums = weighted_normal_equations(cells, weight, rs, sample_period_s, exclude);
  // None and given mode are one solve; ratio mode starts from Eq. 2's n (N = 0 here).
  WeightedSolution out = solve_weighted(sums, sums.given_noise);
  if (!out.ok || rs.eiv != EivCorrection::kNoiseRatio) return out;
  Eigen::Matrix3d n = n_start.allFinite() ? n_start : out.n_uncorrected;
  for (int it = 0; it < 100; ++it) {
    Eigen::Matrix3d noise = Eigen::Matrix3d::Zero();
    for (std::size_t i = 0; i < cells.size(); ++i) {
      const Cell& cell = cells[i];
      const double wg = weight[i] * cell.g;
      if (wg == 0.0 || cell.section == exclude) continue;
      const Eigen::Vector3d e2 = (cell.y - n.transpose() * cell.x).cwiseAbs2();
      noise.diagonal() += wg * ratio_noise_power(e2, scale2[static_cast<std::size_t>(cell.bin)], share);
    }
    Eigen::Matrix3d corrected, corrected_inverse;
    if (!(noise.diagonal().sum() > 0.0) || !solve_corrected(sums, noise, corrected, corrected_inverse)) {
      out.n = out.n_uncorrected;
      out.a_inverse = out.a_inverse_uncorrected;
      out.noise.setZero();
      out.eiv_applied = false;
      return out;
    }
    const bool converged = (corrected - n).cwiseAbs().maxCoeff() < 1e-12;
    n = corrected;
    out.n = n;
    out.a_inverse = corrected_inverse;
    out.noise = noise;
    out.eiv_applied = true;
    if (converged) break;
  }
  return out;
}

/// With the weights frozen, n = (A - N)^-1 C and N = diag_c(w_c^2 G_w + p_c^2 G_p), G_w and G_p
/// the weighted sums of the expected periodogram of unit white and unit 1/f noise over the
/// cells. So dn / d(w_c^2) = G_w (A - N)^-1 e_c e_c^T n: column c of the inverse times row c of n,
/// and likewise for p_c^2; the delta method adds J_c Sigma_c J_c^T per axis c (the axes' levels
/// were fitted separately, so they are independent). This is the first-order effect; the
/// correction is small next to A wherever the estimate is usable.
Matrix9d noise_level_covariance_term(const std::vector<Cell>& cells, const std::vector<double>& weight,
                                     const WeightedSolution& fit, const RobustSettings& rs, double sample_period_s) {
  Matrix9d out = Matrix9d::Zero();
  if (!fit.eiv_applied || rs.eiv != EivCorrection::kGiven) return out;
  NoiseSpectrum unit_white, unit_pink;
  unit_white.white_nT.setOnes();
  unit_pink.pink_nT_per_sqrt_hz.setOnes();
  double g_white = 0.0, g_pink = 0.0;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const double wg = weight[i] * cells[i].g;
    if (wg == 0.0) continue;
    g_white += wg * unit_white.expected_periodogram(cells[i].frequency_hz, sample_period_s, cells[i].length)(0);
    g_pink += wg * unit_pink.expected_periodogram(cells[i].frequency_hz, sample_period_s, cells[i].length)(0);
  }
  for (int c = 0; c < 3; ++c) {
    const Eigen::Matrix2d& sigma = rs.reference_noise_level_covariance[static_cast<std::size_t>(c)];
    if (sigma.isZero(0.0)) continue;
    Eigen::Matrix<double, 9, 2> jacobian;
    for (int r = 0; r < 3; ++r) {
      for (int q = 0; q < 3; ++q) {
        const double dn = fit.a_inverse(r, c) * fit.n(c, q);
        jacobian(3 * r + q, 0) = g_white * dn;
        jacobian(3 * r + q, 1) = g_pink * dn;
      }
    }
    out.noalias() += jacobian * sigma * jacobian.transpose();
  }
  return out;
}

}  // namespace magnetometer_insitu_calibration::detail::robust
