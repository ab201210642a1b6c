// The pair's halves compared, and their spread carried by n's covariance: see halves_split.hpp.
#include "halves_split.hpp"

#include "robust_covariance.hpp"
#include "weighted_eiv_solve.hpp"

#include "magnetometer_insitu_calibration/estimation/estimate_comparison.hpp"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration::detail::robust {

namespace {

using Vector9 = Eigen::Matrix<double, 9, 1>;

/// Two halves of the cells, each solved with the final weights kept and its covariance as n's own.
struct Halves {
  bool ok = false;
  std::string why;  ///< why not, when not ok
  WindowEstimate half[2];
  EstimateComparison comparison;
};

Halves solve_halves(const std::vector<Cell>& cells, const IrlsResult& fit, const std::vector<char>& in_first,
                    std::size_t k_sections, std::size_t bins, const ReferenceNoiseModel* noise,
                    const Regression& regression) {
  Halves out;
  for (int h = 0; h < 2; ++h) {
    IrlsResult part = fit;
    for (std::size_t i = 0; i < cells.size(); ++i) {
      if ((in_first[i] != 0) != (h == 0)) part.weight[i] = 0.0;
    }
    const WeightedSolution solved = solve_frozen(cells, part.weight, regression);
    if (!solved.ok) {
      out.why = "a half has no signal in some direction";
      return out;
    }
    static_cast<WeightedSolution&>(part) = solved;
    const CellCovariance cov = cell_covariance(cells, part, k_sections, bins, solved.eiv_applied ? noise : nullptr, regression);
    out.half[h].n = solved.n;
    out.half[h].n_covariance = cov.covariance;
    out.half[h].covariance_dof = cov.cells;
    out.half[h].parameters = decompose(solved.n, cov.covariance, cov.cells);
  }
  out.comparison = compare_estimates({&out.half[0], &out.half[1]});
  out.ok = out.comparison.assessed;
  if (!out.ok) out.why = out.comparison.unusable;
  return out;
}

/// The smaller of 9 x the smallest parameter p and the joint p (where the joint test decides).
double split_p_value(const EstimateComparison& c) {
  const double parameter_p = std::min(1.0, 9.0 * c.smallest_parameter_p());
  return c.joint_tested && std::isfinite(c.joint_p_value) ? std::min(parameter_p, c.joint_p_value) : parameter_p;
}

/// BandSplitCheck::spread_covariance of two halves (row-major vec(n), as n_covariance).
Matrix9d halves_spread(const Halves& h) {
  constexpr double kJointPoint = 16.919;   // chi2, 9 degrees of freedom, 95 %
  constexpr double kLargestPoint = 7.690;  // chi2, 1 degree, 1 - 0.05 / 9: the largest of 9 at 95 %
  Vector9 d;
  for (int k = 0; k < 9; ++k) d(k) = h.half[0].n(k / 3, k % 3) - h.half[1].n(k / 3, k % 3);
  const Matrix9d v = h.half[0].n_covariance + h.half[1].n_covariance;
  double share = 0.0;
  const Eigen::LDLT<Matrix9d> ldlt(v);
  if (ldlt.info() == Eigen::Success && ldlt.isPositive()) {
    const double joint = d.dot(ldlt.solve(d));
    if (std::isfinite(joint) && joint > kJointPoint) share = 1.0 - kJointPoint / joint;
  }
  for (int k = 0; k < 9; ++k) {
    if (!(v(k, k) > 0.0)) continue;
    const double single = d(k) * d(k) / v(k, k);
    if (single > kLargestPoint) share = std::max(share, 1.0 - kLargestPoint / single);
  }
  return kHalvesSpreadScale * share * (d * d.transpose());
}

/// The activity split's first half: the cells of the weighted sections with the least field, each
/// section's field the sum over components of its share of the component's weighted power
/// sum w g |x_k|^2 (so that the weak vertical counts as much as the horizontals). Empty when
/// fewer than kMinActivitySections sections carry weight.
constexpr std::size_t kMinActivitySections = 8;
std::vector<char> quiet_sections(const std::vector<Cell>& cells, const std::vector<double>& weight, std::size_t k_sections) {
  std::vector<Eigen::Vector3d> power(k_sections, Eigen::Vector3d::Zero());
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const Eigen::Vector3d p = weight[i] * cells[i].g * cells[i].x.cwiseAbs2();
    power[static_cast<std::size_t>(cells[i].section)] += p;
    total += p;
  }
  std::vector<double> activity;
  for (const Eigen::Vector3d& p : power) {
    if (p.sum() > 0.0) activity.push_back(p.cwiseQuotient(total).sum());
  }
  if (activity.size() < kMinActivitySections || !(total.minCoeff() > 0.0)) return {};
  std::vector<double> sorted = activity;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
  const double median = sorted[sorted.size() / 2];
  std::vector<char> first(cells.size(), 0);
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const Eigen::Vector3d& p = power[static_cast<std::size_t>(cells[i].section)];
    first[i] = p.sum() > 0.0 && p.cwiseQuotient(total).sum() < median;
  }
  return first;
}

}  // namespace

BandSplitCheck band_split_check(const std::vector<Cell>& cells, const IrlsResult& fit, std::size_t k_sections,
                                std::size_t bins, const ReferenceNoiseModel* noise, const Regression& regression) {
  BandSplitCheck out;
  std::vector<double> frequencies;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (fit.weight[i] > 0.0) frequencies.push_back(cells[i].frequency_hz);
  }
  if (frequencies.size() < 32) {
    out.text = "band split not assessed: too few cells";
    return out;
  }
  std::nth_element(frequencies.begin(), frequencies.begin() + static_cast<std::ptrdiff_t>(frequencies.size() / 2),
                   frequencies.end());
  const double split_hz = frequencies[frequencies.size() / 2];
  std::vector<char> below(cells.size(), 0);
  for (std::size_t i = 0; i < cells.size(); ++i) below[i] = cells[i].frequency_hz < split_hz;
  const Halves band = solve_halves(cells, fit, below, k_sections, bins, noise, regression);
  if (!band.ok) {
    out.text = "band split not assessed: " + band.why;
    return out;
  }
  const EstimateComparison& c = band.comparison;
  out.assessed = true;
  out.p_value = split_p_value(c);
  out.differs = c.significant(kPairBiasAlpha);
  out.spread_covariance = halves_spread(band);
  std::ostringstream text;
  text.precision(2);
  text << "below and above " << split_hz << " Hz n "
       << (out.differs ? "differs (" : "agrees (") << kParameters[static_cast<std::size_t>(c.least_likely)].name
       << " p " << c.smallest_parameter_p() << ", joint p " << c.joint_p_value << ")"
       << (out.differs ? ": a disturbance both sensors see, or a response the model misses; not vouched for" : "");
  const std::vector<char> quiet = quiet_sections(cells, fit.weight, k_sections);
  const Halves activity = quiet.empty() ? Halves{} : solve_halves(cells, fit, quiet, k_sections, bins, noise, regression);
  if (activity.ok) {
    out.activity_p_value = split_p_value(activity.comparison);
    out.spread_covariance += halves_spread(activity);
    text << "; the sections with the least and the most field: p " << out.activity_p_value;
  }
  out.intervals_widened = !out.spread_covariance.isZero();
  if (out.intervals_widened) text << "; the intervals carry the halves' spread beyond their noise";
  out.text = text.str();
  return out;
}

void widen_by_halves_spread(WindowEstimate& result) {
  if (!result.band_split.intervals_widened) return;
  result.n_covariance += result.band_split.spread_covariance;
  result.parameters = decompose(result.n, result.n_covariance, result.covariance_dof);
  result.intervals += ", plus the spread of the band's halves and of the quiet and active sections beyond their noise";
}

}  // namespace magnetometer_insitu_calibration::detail::robust
