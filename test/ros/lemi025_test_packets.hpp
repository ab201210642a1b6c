// The hand-built LEMI-025 packets of the test_lemi025_driver rostest (its pty tests and its
// recordings): GPS seconds from kT0, a fixed bias, readings that depend on the second.
#pragma once

#include "magnetometer_insitu_calibration/formats/lemi025_packet.hpp"

#include <Eigen/Core>

namespace magnetometer_insitu_calibration {
namespace test {

constexpr double kNanotesla = 1e-9;  // T
constexpr double kT0 = 1709251200.0;  // 2024-03-01T00:00:00Z: GPS time of the first packet
inline const Eigen::Vector3d kBias_nT(21500.0, 502.5, 43000.0);  // nT, multiples of 2.5 nT

/// A packet with known values: bias kBias_nT, reading k component c = (c + 1) * 10 + 0.5 k +
/// 0.25 * (gps - kT0) nT (modulo 100), temperatures depending on the second.
Lemi025Packet make_packet(double gps_s, char gps_status = 'A');

}  // namespace test
}  // namespace magnetometer_insitu_calibration
