// Private to the lemi025_driver node's sources (src/ros/lemi025_driver*.cpp): constants and
// small helpers shared by the port handling, packet timing and diagnostics files.
#pragma once

#include "magnetometer_insitu_calibration/formats/lemi025_packet.hpp"
#include "magnetometer_insitu_calibration/ros/si_units.hpp"

#include <ros/ros.h>

#include <Eigen/Core>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>

namespace magnetometer_insitu_calibration {
namespace lemi025_driver_detail {

constexpr double kBytesPerPacketSecond = static_cast<double>(kLemi025PacketSize);  // 1 packet/s live
constexpr double kBiasChangeWarningHold_s = 60.0;  // wall s a bias change stays a WARN
constexpr double kReadTimeout_s = 0.2;             // s, bounds the shutdown delay
constexpr std::size_t kMaxHeldPackets = 3;         // packets held at once awaiting confirmation

inline std::string gps_status_text(char status) {
  switch (status) {
    case 'A': return "A (active: GPS time)";
    case 'P': return "P (passive: no GPS fix)";
    case 'O': return "O (no GPS antenna)";
    case 'S': return "S (GPS antenna short circuit)";
    default: return std::string(1, status) + " (unknown)";
  }
}

inline std::string vector_text(const Eigen::Vector3d& v) {
  std::ostringstream out;
  out << v(0) << " " << v(1) << " " << v(2);
  return out.str();
}

// Stamp of base_s + offset_s, exact to the nanosecond when base_s is a whole second (GPS time):
// ros::Time::fromSec of a UNIX time in a double would be off by tens of nanoseconds.
inline ros::Time stamp_of(double base_s, double offset_s) {
  if (base_s == std::floor(base_s) && base_s >= 0.0 && base_s < 4294967295.0) {
    return ros::Time(static_cast<std::uint32_t>(base_s)) + ros::Duration(offset_s);
  }
  return ros::Time().fromSec(base_s + offset_s);
}

/// Wall clock (UNIX s), for the times of warnings in the diagnostics.
inline double wall_now_s() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace lemi025_driver_detail
}  // namespace magnetometer_insitu_calibration
