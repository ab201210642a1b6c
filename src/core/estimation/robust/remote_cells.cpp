// The remote reference over the robust estimator's cells (remote_reference.hpp): how strongly
// the remote predicts the local reference, and the pair-only estimate on the same cells and
// weights against the remote's.
#include "remote_cells.hpp"

#include "robust_covariance.hpp"
#include "section_jackknife.hpp"
#include "weighted_eiv_solve.hpp"

#include "magnetometer_insitu_calibration/estimation/estimate_comparison.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>
#include <vector>

namespace magnetometer_insitu_calibration::detail::robust {

namespace {

using Vector9 = Eigen::Matrix<double, 9, 1>;

/// Delete-one-group jackknife of row-major vec(n_pair - n_remote) over the groups n's own
/// covariance uses: the weighted sections, or interleaved frequency groups when there are too few.
JackknifeResult difference_jackknife(const std::vector<Cell>& cells, const std::vector<double>& weight,
                                     std::size_t k_sections, const Regression& pair, const Regression& iv) {
  std::vector<double> section_weight(k_sections, 0.0);
  for (std::size_t i = 0; i < cells.size(); ++i) section_weight[static_cast<std::size_t>(cells[i].section)] += weight[i];
  const bool by_section =
      static_cast<std::size_t>(std::count_if(section_weight.begin(), section_weight.end(),
                                             [](double w) { return w > 0.0; })) >= kMinJackknifeSections;
  const std::size_t groups = by_section ? k_sections : kFrequencyGroups;
  const std::vector<int> group = by_section ? section_groups(cells) : interleaved_frequency_groups(cells, groups);
  const GroupedNormalEquations pair_sums(cells, weight, pair, group, groups), iv_sums(cells, weight, iv, group, groups);
  std::vector<Vector9> leave_out;
  for (std::size_t g = 0; g < groups; ++g) {
    if (!(pair_sums.weight(g) > 0.0)) continue;  // a group of rejected cells: deleting it changes nothing
    const NormalEquations pair_others = pair_sums.without(g), iv_others = iv_sums.without(g);
    const WeightedSolution a = solve_weighted(pair_others, pair_others.given_noise);
    const WeightedSolution b = solve_weighted(iv_others, iv_others.given_noise);
    if (!a.ok || !b.ok) return JackknifeResult{};
    Vector9 d;
    for (int k = 0; k < 9; ++k) d(k) = a.n(k / 3, k % 3) - b.n(k / 3, k % 3);
    leave_out.push_back(d);
  }
  JackknifeResult out = jackknife_statistic(leave_out);
  out.frequency_groups = !by_section;
  return out;
}

}  // namespace

void assess_cells_remote_strength(RemoteReference& remote, const std::vector<Cell>& cells,
                                  const std::vector<double>& weight) {
  Eigen::Matrix3d m_xx = Eigen::Matrix3d::Zero(), m_zz = Eigen::Matrix3d::Zero(), m_zx = Eigen::Matrix3d::Zero();
  double sum = 0.0, sum_squares = 0.0;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const double wg = weight[i] * cells[i].g;
    if (wg == 0.0) continue;
    m_xx.noalias() += wg * (cells[i].x * cells[i].x.adjoint()).real();
    m_zz.noalias() += wg * (cells[i].z * cells[i].z.adjoint()).real();
    m_zx.noalias() += wg * (cells[i].z * cells[i].x.adjoint()).real();
    sum += wg;
    sum_squares += wg * wg;
  }
  // Two real equations per cell.
  const double effective = sum_squares > 0.0 ? 2.0 * sum * sum / sum_squares : 0.0;
  assess_remote_strength(remote, m_xx, m_zz, m_zx, effective);
}

void assess_cells_pair_difference(RemoteReference& remote, const std::vector<Cell>& cells, const IrlsResult& fit,
                                  std::size_t k_sections, const Regression& pair, const Regression& iv,
                                  const ReferenceNoiseModel* noise, double covariance_cells) {
  const WeightedSolution ls = solve_frozen(cells, fit.weight, pair);
  if (!ls.ok) {
    remote.text += "; the pair alone is singular on these cells";
    return;
  }
  // Per cell, the difference of the two estimators' influence, vec_col of (p x 3):
  // A_pair^-1 s_pair - A_iv^-1 s_iv, each score from its own residual.
  Eigen::Matrix<double, 9, 9> omega = Eigen::Matrix<double, 9, 9>::Zero();
  double weight_sum = 0.0;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const Cell& cell = cells[i];
    const double wg = fit.weight[i] * cell.g;
    if (wg == 0.0) continue;
    weight_sum += fit.weight[i];
    const Eigen::Vector3cd e_ls = cell.y - ls.n.transpose() * cell.x;
    const Eigen::Vector3cd e_iv = cell.y - fit.n.transpose() * cell.x;
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    if (ls.eiv_applied) d = pair.noise->expected_periodogram(cell.frequency_hz, pair.sample_period_s, cell.length);
    Vector9 influence;
    for (int l = 0; l < 3; ++l) {
      const Eigen::Vector3d s_ls = wg * ((cell.x * std::conj(e_ls(l))).real() + d.cwiseProduct(ls.n.col(l)));
      const Eigen::Vector3d s_iv = wg * (cell.z * std::conj(e_iv(l))).real();
      influence.segment<3>(3 * l) = ls.a_inverse * s_ls - fit.a_inverse * s_iv;
    }
    omega.noalias() += influence * influence.transpose();
  }
  const double effective = std::max(weight_sum, 4.0);
  omega *= 2.0 * effective / (2.0 * effective - 3.0);
  Matrix9d sandwich;
  for (int r = 0; r < 9; ++r) {
    for (int q = 0; q < 9; ++q) sandwich(r, q) = omega(3 * (r % 3) + r / 3, 3 * (q % 3) + q / 3);  // to row-major
  }
  Matrix9d covariance = combine_covariances(sandwich, difference_jackknife(cells, fit.weight, k_sections, pair, iv));
  if (noise != nullptr) covariance += noise_level_covariance_term(cells, fit.weight, ls, *noise, pair.sample_period_s);
  assess_pair_difference(remote, ls.n, fit.n, covariance, covariance_cells);
}

}  // namespace magnetometer_insitu_calibration::detail::robust
