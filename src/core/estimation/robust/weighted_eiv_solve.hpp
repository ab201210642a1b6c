// The robust estimator's weighted normal equations over the cells and their solve, corrected for
// the reference's noise when one is given (robust_estimator.hpp, steps 3 and 5;
// errors_in_variables.hpp). Not installed: src/core only.
#pragma once

#include "section_cells.hpp"

#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"  // Matrix9d
#include "magnetometer_insitu_calibration/estimation/errors_in_variables.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace magnetometer_insitu_calibration::detail::robust {

/// n from the weighted sums (solve_weighted, solve_frozen): Eq. 2, n = A^-1 C, or, where the
/// reference noise N (nT^2) has power, corrected for it: n = (A - N)^-1 C. ok is false when A
/// is singular; without N, or when A - N is singular, eiv_applied is false and n, a_inverse
/// are Eq. 2's.
struct WeightedSolution {
  bool ok = false;
  bool eiv_applied = false;
  Eigen::Matrix3d n_uncorrected = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d n = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();                      ///< weighted, uncorrected
  Eigen::Matrix3d a_inverse_uncorrected = Eigen::Matrix3d::Zero();  ///< of A
  Eigen::Matrix3d a_inverse = Eigen::Matrix3d::Zero();              ///< of the (corrected) A
  Eigen::Matrix3d noise = Eigen::Matrix3d::Zero();                  ///< N applied, zero if none
};

/// Weighted sums of Eq. 2 over the cells (cell weight w times lambda^gamma g; cells of weight 0
/// and of section `exclude` left out, -1 for none): A = sum w g Re(z x^H) and
/// C = sum w g Re(z y^H) with z the instruments (the reference's own x, or the remote's), and
/// with a reference noise to correct for its expected periodogram N = sum w g E|X_noise|^2
/// (nT^2, diagonal; zero without one).
struct NormalEquations {
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d given_noise = Eigen::Matrix3d::Zero();
  bool instrumental = false;  ///< A is sum w g Re(z x^H) of a remote: solved by LU, never corrected
};

NormalEquations weighted_normal_equations(const std::vector<Cell>& cells, const std::vector<double>& weight,
                                          const Regression& regression);
/// The weighted sums of each group of cells (group[i] in [0, groups); -1: in none), made in one
/// pass, so that a delete-one-group jackknife adds the others' sums instead of summing every
/// cell again per deletion. without(g) equals weighted_normal_equations over the cells outside
/// group g but for the order of the additions (rounding).
class GroupedNormalEquations {
 public:
  GroupedNormalEquations(const std::vector<Cell>& cells, const std::vector<double>& weight,
                         const Regression& regression, const std::vector<int>& group, std::size_t groups);
  NormalEquations without(std::size_t left_out) const;
  /// The sum of the group's cell weights (the IRLS weights, without lambda^gamma): zero for a
  /// group of rejected cells.
  double weight(std::size_t group) const { return weight_[group]; }

 private:
  std::vector<NormalEquations> parts_;
  std::vector<double> weight_;
};
WeightedSolution solve_weighted(const NormalEquations& sums, const Eigen::Matrix3d& noise);
/// n for frozen cell weights: the last step of the IRLS, the band split's halves, the pair-only
/// estimate beside the remote's (the jackknife's refits add GroupedNormalEquations instead).
WeightedSolution solve_frozen(const std::vector<Cell>& cells, const std::vector<double>& weight,
                              const Regression& regression);
/// Step 6d: the covariance of row-major vec(n) that the uncertainty of the noise model's levels
/// (ReferenceNoiseModel::level_covariance) carries through the correction; zero unless the
/// correction was applied.
Matrix9d noise_level_covariance_term(const std::vector<Cell>& cells, const std::vector<double>& weight,
                                     const WeightedSolution& fit, const ReferenceNoiseModel& noise,
                                     double sample_period_s);

}  // namespace magnetometer_insitu_calibration::detail::robust
