// Shared by the programs that check windows of real records against each other (the WIC
// quarters, several days of one pair): each window's six parameters with their standard errors,
// and the quarters' scatter around their weighted mean in units of their intervals.
#pragma once

#include "magnetometer_insitu_calibration/estimation/window_agreement.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"

#include <array>
#include <cmath>
#include <vector>

namespace monte_carlo {

/// The scale ratios x, y, z and the non-orthogonalities xy, xz, yz (deg) of one window, with their
/// standard errors (ci95 / quantile) and the window's ci95 half-width in standard errors (Student's
/// t with the covariance's cells, CalibrationParameters::interval_quantile).
struct SixParameters {
  std::array<double, 6> value{}, se{};
  double quantile = magnetometer_insitu_calibration::kNormalQuantile95;
  double ci95(int k) const { return quantile * se[static_cast<std::size_t>(k)]; }
};

inline SixParameters six_parameters(const magnetometer_insitu_calibration::CalibrationWindow& w) {
  SixParameters s;
  for (int k = 0; k < 6; ++k) {  // the first six of the report's agreement parameters
    const auto p = magnetometer_insitu_calibration::parameter_value(w.estimate.parameters, k);
    s.value[k] = p.value;
    s.se[k] = p.se;
  }
  s.quantile = w.estimate.parameters.interval_quantile;
  return s;
}

/// Per parameter (scale x, y, z; non-orthogonality xy, xz, yz), sqrt(chi2 / (Q - 1)) of the Q
/// disjoint windows of a calibration (the quarters, not the day) around their inverse-variance
/// weighted mean, as calibrate_records reports it (estimation/window_agreement.hpp). The aim for
/// the four 6-hour quarters of the WIC day is <= 1.3; at or below it with probability 0.83 each
/// when the intervals are right (chi^2_3 <= 5.07). NaN when not assessed.
inline std::array<double, 6> quarters_scatter(
    const std::vector<magnetometer_insitu_calibration::CalibrationWindow>& windows) {
  namespace mic = magnetometer_insitu_calibration;
  const mic::WindowAgreement a = mic::check_window_agreement(mic::disjoint_window_estimates(windows));
  std::array<double, 6> out{};
  for (int k = 0; k < 6; ++k) out[k] = a.assessed ? a.parameters[k].birge_ratio : std::nan("");
  return out;
}

}  // namespace monte_carlo
