// Covariance of the robust estimate (robust_estimator.hpp, step 6) and the quality figures over
// the final weighted cells: the sandwich, the cells it rests on, the jackknife, the noise
// levels' term.
#include "robust_covariance.hpp"

#include "../sandwich_cells.hpp"
#include "../spectral_tools.hpp"

#include <cmath>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration::detail::robust {

namespace {

/// Per scale bin, sigma_l^2 of the final residual: the median of |e_l|^2 over the bin's cells
/// divided by ln 2 (the median of an exponential variable is ln 2 times its mean).
std::vector<Eigen::Vector3d> final_scales(const std::vector<Cell>& cells, const Eigen::Matrix3d& n, std::size_t bins) {
  std::vector<Eigen::Vector3d> scale2(bins, Eigen::Vector3d::Zero());
  std::vector<std::vector<double>> per_bin(bins * 3);
  for (const Cell& cell : cells) {
    const Eigen::Vector3d e2 = (cell.y - n.transpose() * cell.x).cwiseAbs2();
    for (int l = 0; l < 3; ++l) per_bin[static_cast<std::size_t>(cell.bin) * 3 + static_cast<std::size_t>(l)].push_back(e2(l));
  }
  for (std::size_t b = 0; b < bins; ++b)
    for (int l = 0; l < 3; ++l) scale2[b](l) = detail::median(per_bin[b * 3 + static_cast<std::size_t>(l)]) / kLn2;
  return scale2;
}

/// The cells the sandwich rests on, counted as cells that share it equally (sandwich_cells.hpp);
/// the weights' sum when a column's residual power is zero in every bin (noise-free records).
double sandwich_cell_count(const std::vector<Cell>& cells, const std::vector<double>& weight,
                           const std::vector<Eigen::Vector3d>& scale2, double weight_sum, const Regression& regression) {
  detail::SandwichCells sandwich_cells(3);
  for (std::size_t i = 0; i < cells.size(); ++i)
    sandwich_cells.add(regression.instrument(cells[i]), weight[i] * cells[i].g, scale2[static_cast<std::size_t>(cells[i].bin)]);
  for (std::size_t i = 0; i < cells.size(); ++i)
    sandwich_cells.share(regression.instrument(cells[i]), weight[i] * cells[i].g, scale2[static_cast<std::size_t>(cells[i].bin)]);
  const double count = sandwich_cells.count();
  return std::isfinite(count) ? count : weight_sum;
}

/// c (I (x) A^-1) Omega (I (x) A^-1)^T of vec_col(n), reordered to row-major vec(n).
Matrix9d sandwich_covariance(const Eigen::Matrix<double, 9, 9>& omega, const Eigen::Matrix3d& a_inverse,
                             double dof_correction) {
  Eigen::Matrix<double, 9, 9> bread = Eigen::Matrix<double, 9, 9>::Zero();
  for (int l = 0; l < 3; ++l) bread.block<3, 3>(3 * l, 3 * l) = a_inverse;
  const Eigen::Matrix<double, 9, 9> cov_col = dof_correction * bread * omega * bread.transpose();
  Matrix9d sandwich;
  for (int r = 0; r < 9; ++r) {
    for (int q = 0; q < 9; ++q) {
      // n(k, l) sits at 3 l + k in vec_col(n) and at 3 k + l in row-major vec(n).
      sandwich(r, q) = cov_col(3 * (r % 3) + r / 3, 3 * (q % 3) + q / 3);
    }
  }
  return sandwich;
}

}  // namespace

CellCovariance cell_covariance(const std::vector<Cell>& cells, const IrlsResult& fit, std::size_t k_sections,
                               std::size_t bins, const ReferenceNoiseModel* noise, const Regression& regression) {
  CellCovariance out;
  const NoiseSpectrum* spectrum = noise != nullptr ? &noise->spectrum : nullptr;
  const double sample_period_s = regression.sample_period_s;
  const std::vector<Eigen::Vector3d> scale2 = final_scales(cells, fit.n, bins);
  // Step 6a: the sandwich's middle over the cells with the final weights; the D_c term centres
  // the score when the errors-in-variables term is used.
  Eigen::Matrix<double, 9, 9> omega = Eigen::Matrix<double, 9, 9>::Zero();
  Eigen::Matrix<double, 9, 1> score;
  Eigen::Vector3d residual_power = Eigen::Vector3d::Zero(), test_power = Eigen::Vector3d::Zero();
  Eigen::Vector3d inband_variance = Eigen::Vector3d::Zero();
  double weight_sum = 0.0, weight_max_sum = 0.0;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const Cell& cell = cells[i];
    const double w = fit.weight[i];
    weight_max_sum += 1.0;
    weight_sum += w;
    const Eigen::Vector3cd e = cell.y - fit.n.transpose() * cell.x;
    const double wg = w * cell.g;
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    if (fit.eiv_applied) d = spectrum->expected_periodogram(cell.frequency_hz, sample_period_s, cell.length);
    for (int l = 0; l < 3; ++l) {
      score.segment<3>(3 * l) = wg * ((regression.instrument(cell) * std::conj(e(l))).real() + d.cwiseProduct(fit.n.col(l)));
    }
    omega.noalias() += score * score.transpose();
    residual_power += w * e.cwiseAbs2();
    test_power += w * cell.y.cwiseAbs2();
    const double l2 = static_cast<double>(cell.length) * static_cast<double>(cell.length);
    inband_variance += (2.0 / l2) * e.cwiseAbs2() / static_cast<double>(k_sections);
  }
  const double effective = std::max(weight_sum, 4.0);
  out.cells = sandwich_cell_count(cells, fit.weight, scale2, weight_sum, regression);
  out.sandwich = sandwich_covariance(omega, fit.a_inverse, 2.0 * effective / (2.0 * effective - 3.0));
  // Step 6b: delete-one-section jackknife with the same final weights; too few sections for
  // their own jackknife: interleaved frequency groups instead.
  out.jackknife = section_jackknife(cells, fit.weight, k_sections, regression);
  if (out.jackknife.sections < kMinJackknifeSections) {
    out.jackknife = frequency_group_jackknife(cells, fit.weight, kFrequencyGroups, regression);
  }
  // Step 6c, then 6d: the identified noise's own uncertainty through the correction (the
  // jackknife re-solves with the same levels, so it does not see it).
  out.covariance = combine_covariances(out.sandwich, out.jackknife);
  out.intervals = out.jackknife.usable()
                      ? "sandwich raised to the jackknife over " + std::to_string(out.jackknife.sections) +
                            (out.jackknife.frequency_groups ? " interleaved frequency groups" : " sections")
                      : std::string("sandwich (no jackknife: too few groups with weight, or one held the whole "
                                    "signal of a direction)");
  if (noise != nullptr) out.level_term = noise_level_covariance_term(cells, fit.weight, fit, *noise, sample_period_s);
  if (!out.level_term.isZero(0.0)) {
    out.covariance += out.level_term;
    out.intervals += ", plus the identified reference noise's uncertainty";
  }
  out.coherence = Eigen::Vector3d::Ones() - residual_power.cwiseQuotient(test_power);
  out.residual_rms_nT = inband_variance.cwiseSqrt();
  out.downweighted_fraction = 1.0 - weight_sum / std::max(weight_max_sum, 1.0);
  return out;
}

}  // namespace magnetometer_insitu_calibration::detail::robust
