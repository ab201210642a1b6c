// rostest test_faults_driver_pc_clock.test (in the test_faults_driver binary, ~suite DriverPcClock).
// DriverPcClock.* runs from test/ros/test_faults_driver_pc_clock.test (~suite), on a driver with
// /use_sim_time, whose PC clock (ros::Time::now, the /clock this test publishes) it steps:
//   PcClockStepsBackwardsAndForwards  GPS lost ('P'): stamps from the PC clock; the clock steps
//                                 back 4.55 s (the 45 readings stamped before the last published one
//                                 are dropped and counted, nothing goes backwards), then forward
//                                 100 s (a gap in the stamps, nothing dropped); both steps counted
#include "faults_driver_test.hpp"

#include <rosgraph_msgs/Clock.h>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/MagneticField.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

using namespace mic::test::faults;
using mic::test::faults::encode;
using mic::test::wait_for;

/// The driver's PC clock is ros::Time::now(); with /use_sim_time it is the /clock published here.
class DriverPcClock : public testing::Test {
 protected:
  static constexpr double kP0 = 1700000000.0;  // PC clock (UNIX s) of the first packet: 2023-11-14

  void SetUp() override {
    ASSERT_NE(g_port, nullptr);
    ASSERT_TRUE(ros::Time::isSimTime()) << "needs /use_sim_time (test_faults_driver_pc_clock.test)";
    clock_pub_ = ros::NodeHandle().advertise<rosgraph_msgs::Clock>("/clock", 10);
    ASSERT_TRUE(wait_for([&] { return clock_pub_.getNumSubscribers() > 0 && g_inbox->connected(); }));
    set_clock(kP0 - 30.0);
    ASSERT_TRUE(wait_for([&] { return g_inbox->value("link", "connected") == "True"; }))
        << "driver not connected to the pty";
    packets_ = std::max(0LL, g_inbox->counter("link", "packets"));
  }
  /// Sets the PC clock to `t_s` and waits until the driver has seen it: its diagnostics (on a
  /// wall-clock timer) are stamped with its ros::Time::now(). Published again while waiting: a
  /// message sent before the driver's /clock subscription is connected is lost (the subscriber
  /// count also counts this test's own subscription).
  void set_clock(double t_s) {
    rosgraph_msgs::Clock clock;
    clock.clock = ros::Time(t_s);
    EXPECT_TRUE(wait_for([&] {
      clock_pub_.publish(clock);
      return g_inbox->last_stamp() == clock.clock;
    }))
        << "the driver's clock did not reach " << t_s << " (its diagnostics say " << g_inbox->last_stamp() << ")";
  }
  /// Sets the PC clock to `t_s`, writes one 'P' packet (no GPS fix) and waits until the driver
  /// has counted it: it took the packet's arrival time (at that clock reading) before.
  void packet_at(double t_s, double gps_s) {
    set_clock(t_s);
    mic::Lemi025Packet p = make_packet(gps_s);
    p.gps_status = 'P';
    port().write(encode(p));
    ++packets_;
    EXPECT_GE(g_inbox->wait_counter("link", "packets", packets_), packets_) << "packet at " << t_s << " not handled";
  }
  /// Waits for `count` readings after `before`, until the driver has read every byte, and for
  /// diagnostics after that.
  void settle(std::size_t before, std::size_t count) {
    EXPECT_TRUE(wait_for([&] { return g_inbox->field_count() >= before + count; }))
        << g_inbox->field_count() - before << " of " << count << " readings";
    g_inbox->wait_all_read(port());
    g_inbox->fresh();
  }
  mic::test::PtyLink& port() { return *g_port; }
  ros::Publisher clock_pub_;
  long long packets_ = 0;  ///< packets written to the driver (its "packets" counter once handled)
};

// GPS lost: the packet stamps come from the PC clock at arrival, the arrival taken as the time of
// the packet's last reading (first reading 0.9 s before). Truth, with P0 = kP0 and packets
// arriving at P0, P0 + 1, P0 + 2: first readings at P0 - 0.9 + j, last published P0 + 2.0.
// The PC clock then steps BACK 4.55 s (NTP correction): packets j = 0..5 arrive at
// P0 - 1.55 + j, first readings at P0 - 2.45 + j. Readings not after P0 + 2.0 are dropped and
// counted: packets 0..3 (40 readings) and readings k = 0..4 of packet 4 (P0 + 1.55 .. + 1.95);
// its k = 5..9 (P0 + 2.05 ..) and packet 5 are published. Then the clock steps FORWARD 100 s:
// stamps restart at the new arrival - 0.9 s, nothing dropped. Both steps counted, WARN.
TEST_F(DriverPcClock, PcClockStepsBackwardsAndForwards) {
  const std::size_t mark = g_inbox->history_size();
  const std::size_t before = g_inbox->field_count();
  const double gps0 = kT0 + 500.0;  // the instrument's (untrusted) clock runs on regardless
  for (int j = 0; j < 3; ++j) packet_at(kP0 + j, gps0 + j);
  settle(before, 30);
  ASSERT_EQ(g_inbox->field_count(), before + 30);
  const long long dropped0 = g_inbox->counter("link", kDropped);
  const long long steps0 = g_inbox->counter("link", "PC clock steps");
  EXPECT_EQ(steps0, 0) << "no step yet";
  EXPECT_EQ(g_inbox->value("instrument", "time source"), "PC clock (GPS status P)");

  const double back = kP0 + 3.0 - 4.55;  // arrival of the first packet after the step back
  for (int j = 0; j < 6; ++j) packet_at(back + j, gps0 + 3 + j);
  const double forward = back + 6.0 + 100.0;  // then the clock jumps 100 s ahead
  for (int j = 0; j < 2; ++j) packet_at(forward + j, gps0 + 9 + j);

  std::vector<double> expected;  // truth, UNIX s
  for (int j = 0; j < 3; ++j)
    for (int k = 0; k < 10; ++k) expected.push_back(kP0 + j - 0.9 + 0.1 * k);
  for (int k = 5; k < 10; ++k) expected.push_back(back + 4 - 0.9 + 0.1 * k);
  for (int k = 0; k < 10; ++k) expected.push_back(back + 5 - 0.9 + 0.1 * k);
  for (int j = 0; j < 2; ++j)
    for (int k = 0; k < 10; ++k) expected.push_back(forward + j - 0.9 + 0.1 * k);
  settle(before, expected.size());
  const auto fields = g_inbox->fields_from(before);
  ASSERT_EQ(fields.size(), expected.size());
  for (std::size_t i = 0; i < fields.size(); ++i) {
    EXPECT_NEAR(fields[i].header.stamp.toSec(), expected[i], 1e-5) << "reading " << i;
    EXPECT_TRUE(std::isfinite(fields[i].magnetic_field.x)) << "reading " << i;
    if (i > 0) {
      EXPECT_GT(fields[i].header.stamp, fields[i - 1].header.stamp) << "reading " << i << " goes backwards";
    }
  }
  EXPECT_EQ(g_inbox->counter("link", kDropped), dropped0 + 45) << "readings stamped before the last published one";
  EXPECT_EQ(g_inbox->counter("link", "PC clock steps"), steps0 + 2);
  EXPECT_EQ(g_inbox->value("link", "last PC clock step (s)"), "100");
  EXPECT_EQ(g_inbox->counter("link", kUnconfirmed), 0) << "PC-clock packets are never held";
  EXPECT_TRUE(g_inbox->any_since(mark, "link", diagnostic_msgs::DiagnosticStatus::WARN, "PC clock steps"))
      << "no WARN 'PC clock steps' in the link diagnostics";
  EXPECT_TRUE(g_inbox->any_since(mark, "link", diagnostic_msgs::DiagnosticStatus::WARN, "readings dropped"))
      << "no WARN 'readings dropped' in the link diagnostics";
  diagnostic_msgs::DiagnosticStatus instrument;
  ASSERT_TRUE(g_inbox->status("instrument", instrument));
  EXPECT_EQ(instrument.level, diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_NE(instrument.message.find("GPS status P"), std::string::npos) << instrument.message;
  EXPECT_EQ(g_inbox->counter("instrument", "packets without GPS"), 3 + 6 + 2);
}

}  // namespace
