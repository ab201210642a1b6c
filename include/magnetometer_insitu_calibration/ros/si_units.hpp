// The ROS boundary's units: sensor_msgs/MagneticField and the package's ScalarField carry tesla
// (SI, REP-103); the core and the files work in nT. Every conversion at the boundary uses these.
#pragma once

namespace magnetometer_insitu_calibration {

inline constexpr double kNanoteslaPerTesla = 1e9;
inline constexpr double kTeslaPerNanotesla = 1e-9;

}  // namespace magnetometer_insitu_calibration
