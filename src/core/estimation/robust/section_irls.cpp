// Sectioned M-estimation of the robust estimator (robust_estimator.hpp, steps 3 and 5):
// iteratively reweighted least squares over the cells with cell weights (cell_weights.hpp:
// Huber's) and section weights from each section's residual level.
#include "section_irls.hpp"

#include "magnetometer_insitu_calibration/estimation/robust/cell_weights.hpp"
#include "../spectral_tools.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace magnetometer_insitu_calibration::detail::robust {

namespace {

/// A section's weight from its level over the typical section's, q: 1 for q <= 2, 2 / q up to
/// `rejection`, then 0 (NaN: 0).
double section_weight(double level_ratio, double rejection) {
  return level_ratio <= 2.0 ? 1.0 : (level_ratio <= rejection ? 2.0 / level_ratio : 0.0);
}

}  // namespace

/// Steps 3 and 5: IRLS over the cells.
IrlsResult irls(const std::vector<Cell>& cells, std::size_t sections, std::size_t bins, const RobustSettings& rs,
                const Regression& regression) {
  IrlsResult out;
  const std::size_t m = cells.size();
  out.weight.assign(m, 1.0);
  out.section_weight.assign(sections, 1.0);
  out.scale2.assign(bins, Eigen::Vector3d::Ones());
  std::vector<double> cell_weight(m, 1.0);
  // Huber weights need a scale that is one level across its bin. When the band's cells make a
  // single bin (a window under about 2 h), that one scale spans the residual's colour (the
  // instruments' 1/f noise, a pier's tilt) and the strong low cells would be down-weighted as
  // outliers: there the cells keep weight 1 (docs/validation.md, design choices). The
  // rejection of wild cells (kCellRejection) and the section weights stay.
  const HuberWeights huber(rs.huber_k);
  const UnitWeights unit;
  const CellWeights& settling = huber_cell_weights(bins) ? static_cast<const CellWeights&>(huber) : unit;
  // After two iterations (scale and n settled) cells beyond kCellRejection sigmas are dropped: a
  // clean cell has d^2 ~ Gamma(3)/3, P(d > 5) ~ 1e-14.
  const RejectingWeights settled(settling, kCellRejection);
  Eigen::Matrix3d n_previous = Eigen::Matrix3d::Constant(kNaN);
  std::vector<double> r2(m, 0.0);
  for (int it = 0; it < rs.iterations; ++it) {
    const CellWeights& weights = it >= 2 ? static_cast<const CellWeights&>(settled) : settling;
    const NormalEquations sums = weighted_normal_equations(cells, out.weight, regression);
    // N is zero without a noise to correct for: Eq. 2 with the weights.
    const WeightedSolution solved = solve_weighted(sums, sums.given_noise);
    if (!solved.ok) return out;
    static_cast<WeightedSolution&>(out) = solved;  // n, A and the correction; the weights stay
    out.iterations = it + 1;
    // Residuals, frequency-resolved robust scale, new weights.
    std::vector<std::vector<double>> per_bin(bins * 3);
    std::vector<Eigen::Vector3d> e2(m);
    for (std::size_t i = 0; i < m; ++i) {
      const Eigen::Vector3cd e = cells[i].y - out.n.transpose() * cells[i].x;
      e2[i] = e.cwiseAbs2();
      for (int l = 0; l < 3; ++l) per_bin[static_cast<std::size_t>(cells[i].bin) * 3 + static_cast<std::size_t>(l)].push_back(e2[i](l));
    }
    for (std::size_t b = 0; b < bins; ++b) {
      for (int l = 0; l < 3; ++l) {
        const double med = detail::median(per_bin[b * 3 + static_cast<std::size_t>(l)]);
        out.scale2[b](l) = std::max(med / kLn2, std::numeric_limits<double>::min());
      }
    }
    std::vector<std::vector<double>> section_r2(sections);
    for (std::size_t i = 0; i < m; ++i) {
      r2[i] = e2[i].cwiseQuotient(out.scale2[static_cast<std::size_t>(cells[i].bin)]).sum();
      const double d = std::sqrt(r2[i] / 3.0);  // sigmas
      cell_weight[i] = weights.weight(d);
      section_r2[static_cast<std::size_t>(cells[i].section)].push_back(std::min(r2[i] / 3.0, kLevelCap));
    }
    // Section level: mean of the capped d^2 of its cells (1 for a clean section, +-0.1 for 100
    // cells). The cap keeps one wild cell from rejecting a section; a step or a parked vehicle
    // (residual raised over many cells) lifts the mean well above the other sections'.
    std::vector<double> level(sections, kNaN), finite_levels;
    for (std::size_t s = 0; s < sections; ++s) {
      if (section_r2[s].empty()) continue;
      double sum = 0.0;
      for (double v : section_r2[s]) sum += v;
      level[s] = sum / static_cast<double>(section_r2[s].size());
      finite_levels.push_back(level[s]);
    }
    const double typical = std::max(1.0, detail::median(finite_levels));
    for (std::size_t s = 0; s < sections; ++s) {
      const double q = std::isfinite(level[s]) ? level[s] / typical : 1.0;
      out.section_weight[s] = section_weight(q, rs.section_rejection);
    }
    for (std::size_t i = 0; i < m; ++i) {
      out.weight[i] = cell_weight[i] * out.section_weight[static_cast<std::size_t>(cells[i].section)];
    }
    const bool converged = n_previous.allFinite() && (out.n - n_previous).cwiseAbs().maxCoeff() < 1e-11;
    n_previous = out.n;
    if (converged) break;
  }
  return out;
}

}  // namespace magnetometer_insitu_calibration::detail::robust
