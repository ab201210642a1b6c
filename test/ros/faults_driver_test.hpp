// Shared by the two files of the test_faults_driver rostest binary (test_faults_driver.cpp: line
// faults and main(); test_faults_driver_pc_clock.cpp: PC clock steps): the packets they write,
// the counters they read, and the one pty and inbox of the run.
#pragma once

#include "magnetometer_insitu_calibration/formats/lemi025_packet.hpp"
#include "driver_test_support.hpp"
#include "pty_link.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace magnetometer_insitu_calibration {
namespace test {
namespace faults {

constexpr double kNanotesla = 1e-9;   // T
constexpr double kT0 = 1709251200.0;  // 2024-03-01T00:00:00Z
inline const Eigen::Vector3d kBias_nT(21500.0, 502.5, 43000.0);  // nT
constexpr const char* kDropped = "readings dropped (stamp not after the previous)";
constexpr const char* kInvalid = "readings published as NaN (invalid)";
constexpr const char* kUnconfirmed = "packets dropped (isolated GPS time jump)";
constexpr const char* kConfirmed = "GPS time jumps confirmed";

/// A GPS-stamped packet of second gps_s: bias kBias_nT, readings depending on the second.
Lemi025Packet make_packet(double gps_s);
using test::encode;
/// The bytes (sum8) of make_packet(gps_s).
std::vector<std::uint8_t> encode(double gps_s);
void append(std::vector<std::uint8_t>& to, const std::vector<std::uint8_t>& bytes);

/// What the driver publishes: its readings and its diagnostics.
class Inbox : public DriverInbox {
 public:
  Inbox();
  bool connected() const { return fields_connected(); }
};

/// The pty the driver of the .test file reads, and what it publishes (set by main()).
extern PtyLink* g_port;
extern Inbox* g_inbox;

}  // namespace faults
}  // namespace test
}  // namespace magnetometer_insitu_calibration
