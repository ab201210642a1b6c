// How far a test instrument's parameters may depart from an ideal instrument aligned with the
// reference: the yardstick of the report's verdicts (pipeline/tolerance_verdicts.hpp).
//
// Defaults: INTERMAGNET's 1-second vector magnetometer standard (INTERMAGNET technical manual,
// 1-second instrumentation specifications): scale (and linearity) within 1 %, the axes
// orthogonal within 2 mrad. INTERMAGNET states no misalignment between two variometers; the
// default takes the same 2 mrad. A user gives their own in a YAML file (formats/tolerance_file.hpp):
// a coil laboratory's +-0.04 % and +-0.02 deg, or the instrument's data sheet.
#pragma once

#include <Eigen/Core>

#include <string>

namespace magnetometer_insitu_calibration {

/// 2 mrad in degrees.
constexpr double kTwoMilliradiansDeg = 0.002 * 57.29577951308232;

struct Tolerances {
  /// Largest |scale ratio - 1| per test axis x, y, z, as a fraction (0.01 = 1 %).
  Eigen::Vector3d scale = Eigen::Vector3d::Constant(0.01);
  /// Largest |non-orthogonality| per axis pair xy, xz, yz, degrees.
  Eigen::Vector3d nonorthogonality_deg = Eigen::Vector3d::Constant(kTwoMilliradiansDeg);
  /// Largest |misalignment| per rotation-vector component about reference x, y, z, degrees.
  Eigen::Vector3d misalignment_deg = Eigen::Vector3d::Constant(kTwoMilliradiansDeg);
  /// Where the values come from, for the report ("INTERMAGNET 1-second standard", a file's path).
  std::string source = "INTERMAGNET 1-second standard (scale 1 %, orthogonality 2 mrad; misalignment 2 mrad)";

  /// Throws InputError naming the field (scale, nonorthogonality_deg, misalignment_deg) when a
  /// value is not a positive finite number.
  void validate() const;
};

}  // namespace magnetometer_insitu_calibration
