// The robust estimator's M-step (robust_estimator.hpp, steps 3 and 5): iteratively reweighted
// least squares over the cells with cell weights (cell_weights.hpp) and section weights. Not
// installed: src/core only.
#pragma once

#include "section_cells.hpp"
#include "weighted_eiv_solve.hpp"

#include "magnetometer_insitu_calibration/estimation/estimator_settings.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace magnetometer_insitu_calibration::detail::robust {

constexpr double kCellRejection = 5.0;  // sigmas (d) beyond which a cell gets weight 0
constexpr double kLevelCap = 25.0;      // cap of a cell's d^2 in its section's level

/// The IRLS: the solution with its last weights, and those weights.
struct IrlsResult : WeightedSolution {
  std::vector<double> weight;          ///< per cell (cell x section)
  std::vector<double> section_weight;
  std::vector<Eigen::Vector3d> scale2; ///< per bin, sigma_l^2
  int iterations = 0;
};

/// True when the cells' Huber weights apply: more than one scale bin, so that the scale can
/// follow the residual's colour across the band (section_irls.cpp).
inline bool huber_cell_weights(std::size_t scale_bins) { return scale_bins > 1; }
/// WindowEstimate::weights of the robust estimator with `scale_bins` bins.
inline const char* robust_weights_text(std::size_t scale_bins) {
  return huber_cell_weights(scale_bins) ? "lambda^gamma x Huber cell x section"
                                        : "lambda^gamma x section (one scale bin: no Huber cell weights)";
}

/// Steps 3 and 5: IRLS over the cells.
IrlsResult irls(const std::vector<Cell>& cells, std::size_t sections, std::size_t bins, const RobustSettings& rs,
                const Regression& regression);

}  // namespace magnetometer_insitu_calibration::detail::robust
