// Shared by the programs that check windows of real records against each other (the WIC
// quarters, several days of one pair): each window's six parameters with their standard errors,
// and the quarters' scatter around their weighted mean in units of their intervals.
#pragma once

#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"

#include <array>
#include <cmath>
#include <vector>

namespace monte_carlo {

/// ci95 half-width / standard error.
constexpr double kZ95 = 1.959964;

/// The scale ratios x, y, z and the non-orthogonalities xy, xz, yz (deg) of one window, with their
/// standard errors (ci95 / kZ95).
struct SixParameters {
  std::array<double, 6> value{}, se{};
};

inline SixParameters six_parameters(const magnetometer_insitu_calibration::CalibrationWindow& w) {
  const auto& p = w.estimate.parameters;
  SixParameters s;
  for (int k = 0; k < 3; ++k) {
    s.value[k] = p.scale_ratio(k);
    s.se[k] = p.scale_ratio_ci95(k) / kZ95;
    s.value[k + 3] = p.nonorthogonality_deg(k);
    s.se[k + 3] = p.nonorthogonality_ci95_deg(k) / kZ95;
  }
  return s;
}

/// Per parameter, sqrt(chi2 / (Q - 1)) of Q windows around their inverse-variance weighted mean
/// (issue 13 asks <= 1.3 for the four 6-hour quarters of the WIC day; at or below it with
/// probability 0.83 each when the intervals are right, chi^2_3 <= 5.07). Needs Q >= 2.
inline std::array<double, 6> quarters_scatter(const std::vector<SixParameters>& quarters) {
  std::array<double, 6> out{};
  for (int k = 0; k < 6; ++k) {
    double sw = 0.0, swx = 0.0;
    for (const auto& q : quarters) {
      sw += 1.0 / (q.se[k] * q.se[k]);
      swx += q.value[k] / (q.se[k] * q.se[k]);
    }
    const double mean = swx / sw;
    double chi2 = 0.0;
    for (const auto& q : quarters) chi2 += (q.value[k] - mean) * (q.value[k] - mean) / (q.se[k] * q.se[k]);
    out[k] = std::sqrt(chi2 / static_cast<double>(quarters.size() - 1));
  }
  return out;
}

}  // namespace monte_carlo
