// Shared by the Monte Carlo programs: one window's errors against the truth, as the accuracy
// tables state them.
#pragma once

#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>

namespace monte_carlo {

struct ParameterErrors {
  double scale_pct = 0.0;  ///< the largest |error| of the three scale ratios, %
  double angle_deg = 0.0;  ///< the largest |error| of the three non-orthogonalities and three misalignments, deg
  int covered = 0;         ///< how many of the nine parameters' 95 % intervals hold the truth
};

/// The window's parameters `q` against the decomposition of the true matrix `truth`.
inline ParameterErrors parameter_errors(const magnetometer_insitu_calibration::CalibrationParameters& q,
                                        const Eigen::Matrix3d& truth) {
  const magnetometer_insitu_calibration::CalibrationParameters t = magnetometer_insitu_calibration::decompose(truth);
  const Eigen::Vector3d ds = 100.0 * (q.scale_ratio - t.scale_ratio);
  const Eigen::Vector3d dn = q.nonorthogonality_deg - t.nonorthogonality_deg, dm = q.misalignment_deg - t.misalignment_deg;
  ParameterErrors e;
  e.scale_pct = ds.cwiseAbs().maxCoeff();
  e.angle_deg = std::max(dn.cwiseAbs().maxCoeff(), dm.cwiseAbs().maxCoeff());
  for (int l = 0; l < 3; ++l) {
    e.covered += std::abs(ds(l)) <= 100.0 * q.scale_ratio_ci95(l);
    e.covered += std::abs(dn(l)) <= q.nonorthogonality_ci95_deg(l);
    e.covered += std::abs(dm(l)) <= q.misalignment_ci95_deg(l);
  }
  return e;
}

}  // namespace monte_carlo
