// The robust estimator's covariance of n over its final weighted cells (robust_estimator.hpp,
// step 6) and the window's quality figures. Not installed: src/core only.
#pragma once

#include "section_cells.hpp"
#include "section_irls.hpp"
#include "section_jackknife.hpp"

#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"  // Matrix9d
#include "magnetometer_insitu_calibration/estimation/errors_in_variables.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration::detail::robust {

/// Step 6 over the final weighted cells: the reported covariance of row-major vec(n) and its
/// parts, and the window's quality figures.
struct CellCovariance {
  Matrix9d covariance = Matrix9d::Zero();  ///< reported: 6c, plus 6d
  Matrix9d sandwich = Matrix9d::Zero();    ///< 6a
  JackknifeResult jackknife;               ///< 6b
  Matrix9d level_term = Matrix9d::Zero();  ///< 6d
  double cells = 0.0;                      ///< the cells the sandwich rests on (WindowEstimate::covariance_dof)
  std::string intervals;                   ///< WindowEstimate::intervals
  Eigen::Vector3d coherence = Eigen::Vector3d::Zero();        ///< 1 - weighted residual power / test power
  Eigen::Vector3d residual_rms_nT = Eigen::Vector3d::Zero();  ///< in-band rms of the residual, nT
  double downweighted_fraction = 0.0;      ///< share of cell weight removed by the M-step
};
/// `noise`: the model n was corrected with (null: none).
CellCovariance cell_covariance(const std::vector<Cell>& cells, const IrlsResult& fit, std::size_t k_sections,
                               std::size_t bins, const ReferenceNoiseModel* noise, const Regression& regression);

}  // namespace magnetometer_insitu_calibration::detail::robust
