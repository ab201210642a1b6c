// Weighted normal equations of the robust estimator over its cells, and their solution with or
// without the errors-in-variables correction (robust_estimator.hpp, steps 3 and 5; the
// correction itself: errors_in_variables.hpp).
#include "weighted_eiv_solve.hpp"

#include "magnetometer_insitu_calibration/estimation/errors_in_variables.hpp"
#include "magnetometer_insitu_calibration/estimation/remote_reference.hpp"  // instrumental_solve

#include <Eigen/LU>

#include <cmath>

namespace magnetometer_insitu_calibration::detail::robust {

namespace {

/// One cell's terms of the weighted sums, added to `sums` (wg: its weight times g).
void add_cell(NormalEquations& sums, const Cell& cell, double wg, const Regression& regression,
              const NoiseSpectrum* noise) {
  const Eigen::Vector3cd& z = regression.instrument(cell);
  sums.a.noalias() += wg * (z * cell.x.adjoint()).real();
  sums.c.noalias() += wg * (z * cell.y.adjoint()).real();
  if (noise != nullptr) {
    sums.given_noise.diagonal() +=
        wg * noise->expected_periodogram(cell.frequency_hz, regression.sample_period_s, cell.length);
  }
}

}  // namespace

NormalEquations weighted_normal_equations(const std::vector<Cell>& cells, const std::vector<double>& weight,
                                          const Regression& regression) {
  NormalEquations out;
  out.instrumental = regression.on_remote();
  const NoiseSpectrum* noise = regression.on_remote() ? nullptr : regression.noise;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const double wg = weight[i] * cells[i].g;
    if (wg == 0.0) continue;
    add_cell(out, cells[i], wg, regression, noise);
  }
  return out;
}

GroupedNormalEquations::GroupedNormalEquations(const std::vector<Cell>& cells, const std::vector<double>& weight,
                                               const Regression& regression, const std::vector<int>& group,
                                               std::size_t groups)
    : parts_(groups), weight_(groups, 0.0) {
  const NoiseSpectrum* noise = regression.on_remote() ? nullptr : regression.noise;
  for (NormalEquations& part : parts_) part.instrumental = regression.on_remote();
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const double wg = weight[i] * cells[i].g;
    if (group[i] < 0) continue;
    const std::size_t g = static_cast<std::size_t>(group[i]);
    weight_[g] += weight[i];
    if (wg != 0.0) add_cell(parts_[g], cells[i], wg, regression, noise);
  }
}

NormalEquations GroupedNormalEquations::without(std::size_t left_out) const {
  NormalEquations out;
  out.instrumental = parts_.empty() ? false : parts_.front().instrumental;
  for (std::size_t g = 0; g < parts_.size(); ++g) {
    if (g == left_out) continue;
    out.a += parts_[g].a;
    out.c += parts_[g].c;
    out.given_noise += parts_[g].given_noise;
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
  if (sums.instrumental) {  // the remote's instruments: no correction (remote_reference.hpp)
    Eigen::MatrixXd solution, inverse;
    if (!instrumental_solve(sums.a, sums.c, solution, inverse)) return out;
    out.ok = true;
    out.a = sums.a;
    out.n = out.n_uncorrected = solution;
    out.a_inverse = out.a_inverse_uncorrected = inverse;
    return out;
  }
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

WeightedSolution solve_frozen(const std::vector<Cell>& cells, const std::vector<double>& weight,
                              const Regression& regression) {
  const NormalEquations sums = weighted_normal_equations(cells, weight, regression);
  return solve_weighted(sums, sums.given_noise);
}

/// With the weights frozen, n = (A - N)^-1 C and N = diag_c(w_c^2 G_w + p_c^2 G_p), G_w and G_p
/// the weighted sums of the expected periodogram of unit white and unit 1/f noise over the
/// cells. So dn / d(w_c^2) = G_w (A - N)^-1 e_c e_c^T n: column c of the inverse times row c of n,
/// and likewise for p_c^2; the delta method adds J_c Sigma_c J_c^T per axis c (the axes' levels
/// were fitted separately, so they are independent). This is the first-order effect; the
/// correction is small next to A wherever the estimate is usable.
Matrix9d noise_level_covariance_term(const std::vector<Cell>& cells, const std::vector<double>& weight,
                                     const WeightedSolution& fit, const ReferenceNoiseModel& noise,
                                     double sample_period_s) {
  Matrix9d out = Matrix9d::Zero();
  if (!fit.eiv_applied) return out;
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
    const Eigen::Matrix2d& sigma = noise.level_covariance[static_cast<std::size_t>(c)];
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
