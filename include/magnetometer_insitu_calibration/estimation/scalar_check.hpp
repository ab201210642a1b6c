// The reference checked against an absolute scalar magnetometer (proton, Overhauser, optically
// pumped: F = |B|, 1 nT absolute at every INTERMAGNET observatory).
//
// In the band (0.0002-0.01 Hz) F's variation is the projection of the field's variation on the
// main field's direction b: dF = b . dB. A reference that reads R = k B (its scale k per axis,
// here one k along the field) gives, by Eq. 2 with F as the response (the trend column as ever),
//   F = R c + trend,   c = b / k,
// so |c| = 1 / k: the reference's absolute scale along the main field, k = 1 / |c|, with no
// second vector instrument's noise in it; c / |c| is the field's direction in the reference's
// frame (its direction cosines). With a given direction b0 (the observatory's D and I from its
// absolute observations), c_l = b0_l / k_l gives each axis's own scale where b0_l is not small.
// Through the calibration T = R n the test's coefficients are c_T = n^-1 c: the test's scale
// along the field 1 / |c_T|.
//
// Intervals: 95 % half-widths by the delta method from c's covariance (its Student quantile at
// c's cells); for the test, n's covariance is added as if independent of c's (both rest on the
// same reference: the test's half-width is then somewhat too wide rather than too narrow).
#pragma once

#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"

#include <Eigen/Core>

#include <limits>
#include <optional>
#include <string>

namespace magnetometer_insitu_calibration {

/// The observatory's main-field direction in the reference's frame: declination and
/// inclination, degrees (frame: x north (or H), y east, z down).
struct FieldDirection {
  double declination_deg = 0.0, inclination_deg = 0.0;
  bool hdz = false;  ///< the reference's x is along H (HDZ-oriented): b = (cos I, 0, sin I)
  Eigen::Vector3d unit() const;
};

/// "D,I" or "D,I,hdz" (degrees, |I| <= 90), as calibrate_records --field-direction and
/// calibration_node ~field_direction take it; std::invalid_argument naming what was expected.
FieldDirection parse_field_direction(const std::string& text);

struct ScalarCheck {
  bool assessed = false;
  std::string text;  ///< what was found, or why not assessed
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  Eigen::Vector3d coefficients = Eigen::Vector3d::Constant(kNaN);  ///< c (per nT of each reference axis)
  Eigen::Matrix3d coefficients_covariance = Eigen::Matrix3d::Constant(kNaN);
  double cells = kNaN;                            ///< dof of that covariance
  double reference_scale = kNaN, reference_scale_ci95 = kNaN;  ///< k = 1 / |c|
  Eigen::Vector3d direction_cosines = Eigen::Vector3d::Constant(kNaN), direction_cosines_ci95 = Eigen::Vector3d::Constant(kNaN);
  /// With a given direction: each axis's scale b0_l / c_l (NaN where |b0_l| < 0.2) and the angle
  /// between the fitted and the given direction, degrees.
  Eigen::Vector3d axis_scale = Eigen::Vector3d::Constant(kNaN), axis_scale_ci95 = Eigen::Vector3d::Constant(kNaN);
  double direction_offset_deg = kNaN, direction_offset_ci95_deg = kNaN;
  double test_scale = kNaN, test_scale_ci95 = kNaN;  ///< 1 / |n^-1 c|
  double delay_s = kNaN;                            ///< F minus the reference, s (the fit's)
  /// The reference's scale departs from 1 beyond its interval: the reference needs calibration.
  bool reference_off = false;
};

/// The quantities above from the fitted c (its covariance, cells and interval quantile) and the
/// window's n (with its covariance); `given`: the field's direction, when known.
ScalarCheck assess_scalar(const Eigen::Vector3d& c, const Eigen::Matrix3d& covariance, double cells,
                          const Eigen::Matrix3d& n, const Matrix9d& n_covariance,
                          const std::optional<FieldDirection>& given);

}  // namespace magnetometer_insitu_calibration
