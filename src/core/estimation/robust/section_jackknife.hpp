// The robust estimator's delete-one-group jackknife of n (robust_estimator.hpp, steps 6b and
// 6c): over the weighted sections, or over interleaved frequency groups in windows with too few
// sections, and its combination with the sandwich. Not installed: src/core only.
#pragma once

#include "section_cells.hpp"
#include "weighted_eiv_solve.hpp"

#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"  // Matrix9d

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace magnetometer_insitu_calibration::detail::robust {

// Fewest weighted sections for which the section jackknife enters the covariance (step 6c);
// below, the jackknife is over kFrequencyGroups interleaved frequency groups instead.
constexpr std::size_t kMinJackknifeSections = 6;
constexpr std::size_t kFrequencyGroups = 8;

/// Delete-one-group jackknife of row-major vec(n) (step 6b): groups are sections, or interleaved
/// frequency groups in windows with too few sections.
struct JackknifeResult {
  Matrix9d covariance = Matrix9d::Constant(kNaN);
  std::size_t sections = 0;  ///< groups that carried weight (sections or frequency groups)
  bool frequency_groups = false;  ///< the groups are interleaved frequency groups
  /// Enough groups with weight (kMinJackknifeSections) and a finite J: it enters the covariance.
  bool usable() const { return sections >= kMinJackknifeSections && covariance.allFinite(); }
};

JackknifeResult section_jackknife(const std::vector<Cell>& cells, const std::vector<double>& weight,
                                  std::size_t k_sections, const Regression& regression);
/// Delete-one-group jackknife over `groups` interleaved frequency groups (the cells in frequency
/// order, every groups-th in one group), n refitted without each group with the same weights
/// (step 6b for windows of fewer than kMinJackknifeSections weighted sections).
JackknifeResult frequency_group_jackknife(const std::vector<Cell>& cells, const std::vector<double>& weight,
                                          std::size_t groups, const Regression& regression);
/// The jackknife's groups of the cells (for GroupedNormalEquations): each cell's section, or its
/// interleaved frequency group (the cells in frequency order, every groups-th in one group).
std::vector<int> section_groups(const std::vector<Cell>& cells);
std::vector<int> interleaved_frequency_groups(const std::vector<Cell>& cells, std::size_t groups);
Matrix9d combine_covariances(const Matrix9d& sandwich, const JackknifeResult& jack);
/// J = (G-1)/G sum (v_g - mean)(v_g - mean)^T of leave-one-group-out values of row-major vec(n).
JackknifeResult jackknife_statistic(const std::vector<Eigen::Matrix<double, 9, 1>>& leave_out);

}  // namespace magnetometer_insitu_calibration::detail::robust
