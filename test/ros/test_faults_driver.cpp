// Fault injection on lemi025_driver's serial line (rostest with a real master; started by
// test/ros/test_faults_driver.test, which launches the driver on a pty's symlink, checksum sum8).
// Each fault is asserted on what is published (every good packet, nothing else), on the
// diagnostics counters, and on stamps only growing. Faults ALREADY covered elsewhere, not
// repeated here (test/ros/test_lemi025_driver.cpp): garbage bytes BETWEEN packets and a packet
// with a wrong checksum; a clock step backwards (several packets); serial unplug/replug BETWEEN
// packets; GPS status lost ('P', PC-clock stamps, WARN) and regained; NaN/implausible readings
// from a compact-flash image. New here (run in declaration order, GPS seconds always growing):
//   LineCutMidPacketAndRestored   the pty hangs up after 80 of a packet's 152 bytes; a new pty
//                                 appears; the half packet is not published (nor glued to the
//                                 next bytes), every later packet is; disconnect/reconnect counted
//   LineStallsMidPacket           the line stays up but the rest of a packet never comes (power
//                                 glitch of the instrument): the next whole packet is published,
//                                 one packet late (a GPS second after a lost one waits for the next
//                                 packet to confirm it: the driver's documented 1-packet delay)
//   BytesDroppedInsidePacket      30 bytes missing from the middle of a packet: that packet is
//                                 lost (unavoidable), the following one (whose header then sits
//                                 inside the parser's 152-byte frame) is NOT lost; resync counted
//   GarbageInsertedInsidePacket   5 noise bytes inside a packet: same
//   ImplausibleReadingsLiveAreNaN a checksum-valid packet with 4 readings of +-1e6 nT (failing
//                                 ADC): those 4 published as NaN (x, y, z) and counted, its 6 other
//                                 readings and the neighbours exact, no resync
//   DuplicatedPacketPublishedOnce the same packet twice (repeater/buffer replay): its 10 readings
//                                 published once, 10 counted as dropped, WARN
//   ClockJumpsForwardThenContinues GPS time steps forward 1 h and runs on (real re-synchronisation):
//                                 everything published (the jump confirmed by the next packet),
//                                 time jump and confirmation counted, nothing dropped
//   SingleForwardGlitchDoesNotBlockData  one packet with a GPS second 1 day ahead (valid checksum)
//                                 between correct seconds: the glitch is dropped and counted, every
//                                 good packet published with its GPS stamp
// DriverPcClock.* (test_faults_driver_pc_clock.cpp) runs from test_faults_driver_pc_clock.test
// (~suite); main() is here.
#include "faults_driver_test.hpp"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/MagneticField.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace magnetometer_insitu_calibration {
namespace test {
namespace faults {

Lemi025Packet make_packet(double gps_s) {
  Lemi025Packet p;
  p.station = 3;
  p.gps_time_s = gps_s;
  const double i = std::fmod(gps_s - kT0, 40.0);
  p.sensor_temperature_C = 20.0 + 0.01 * i;
  p.electronics_temperature_C = 30.0;
  p.dac_counts = {{1, 2, 3}};
  p.bias_nT = kBias_nT;
  for (int k = 0; k < kLemi025ReadingsPerPacket; ++k)
    for (int c = 0; c < 3; ++c) p.variation_nT(k, c) = (c + 1) * 10.0 + 0.5 * k + 0.25 * i;
  p.mode = 2;
  p.flash_free_percent = 50;
  p.supply_V = 12.0;
  p.gps_status = 'A';
  return p;
}

std::vector<std::uint8_t> encode(double gps_s) { return encode(make_packet(gps_s)); }

void append(std::vector<std::uint8_t>& to, const std::vector<std::uint8_t>& bytes) {
  to.insert(to.end(), bytes.begin(), bytes.end());
}

Inbox::Inbox() : DriverInbox(param("driver_namespace", "/faults"), param("driver_node_name", "faults/lemi_driver")) {}

PtyLink* g_port = nullptr;
Inbox* g_inbox = nullptr;

}  // namespace faults
}  // namespace test
}  // namespace magnetometer_insitu_calibration

namespace {

using namespace mic::test::faults;
using mic::test::faults::encode;
using mic::test::gps_stamp;
using mic::test::param;
using mic::test::wait_for;

class DriverFaults : public testing::Test {
 protected:
  void SetUp() override {
    ASSERT_NE(g_port, nullptr);
    mic::test::assert_driver_on_pty([] { return g_inbox->connected(); }, *g_inbox);
  }
  Inbox& inbox() { return *g_inbox; }
  mic::test::PtyLink& port() { return *g_port; }

  /// Writes `bytes`, waits for `expected` readings, then until the driver has read every byte.
  std::vector<sensor_msgs::MagneticField> write_and_collect(const std::vector<std::uint8_t>& bytes,
                                                            std::size_t expected) {
    return inbox().write_and_collect(port(), bytes, expected);
  }

  /// The readings are exactly the 10 readings of each of `seconds`, in order, with their values.
  static void expect_packets(const std::vector<sensor_msgs::MagneticField>& fields, const std::vector<double>& seconds) {
    ASSERT_EQ(fields.size(), 10 * seconds.size());
    for (std::size_t i = 0; i < fields.size(); ++i) {
      const double s = seconds[i / 10];
      const int k = static_cast<int>(i % 10);
      EXPECT_EQ(fields[i].header.stamp, gps_stamp(s, k)) << "reading " << i;
      const mic::Lemi025Packet p = make_packet(s);
      EXPECT_NEAR(fields[i].magnetic_field.x, (kBias_nT(0) + p.variation_nT(k, 0)) * kNanotesla, 1e-4 * kNanotesla);
      EXPECT_NEAR(fields[i].magnetic_field.z, (kBias_nT(2) + p.variation_nT(k, 2)) * kNanotesla, 1e-4 * kNanotesla);
    }
  }
  void expect_all_increasing() { inbox().expect_all_stamps_increasing(); }
};

TEST_F(DriverFaults, LineCutMidPacketAndRestored) {
  const long long disconnects0 = inbox().counter("link", "disconnects");
  const long long reconnects0 = inbox().counter("link", "reconnects");
  std::vector<std::uint8_t> bytes = encode(kT0);
  append(bytes, encode(kT0 + 1));
  std::vector<std::uint8_t> half = encode(kT0 + 2);
  half.resize(80);
  append(bytes, half);
  const std::size_t before = inbox().field_count();
  port().write(bytes);
  ASSERT_TRUE(wait_for([&] { return inbox().field_count() >= before + 20; }));
  inbox().wait_all_read(port());  // the driver has read the half packet too
  port().close();                 // cut mid-packet
  EXPECT_TRUE(wait_for([&] { return inbox().value("link", "connected") == "False"; }));
  diagnostic_msgs::DiagnosticStatus link;
  ASSERT_TRUE(inbox().status("link", link));
  EXPECT_EQ(link.level, diagnostic_msgs::DiagnosticStatus::ERROR) << link.message;
  ASSERT_EQ(port().open(), "");  // restored: a new pty under the same link
  ASSERT_TRUE(wait_for([&] { return inbox().value("link", "connected") == "True"; }));
  // The rest of the cut packet never comes; the instrument goes on with whole packets.
  std::vector<std::uint8_t> after = encode(kT0 + 3);
  append(after, encode(kT0 + 4));
  write_and_collect(after, 20);
  expect_packets(inbox().fields_from(before), {kT0, kT0 + 1, kT0 + 3, kT0 + 4});
  EXPECT_EQ(inbox().wait_counter("link", "disconnects", disconnects0 + 1), disconnects0 + 1);
  EXPECT_GE(inbox().wait_counter("link", "reconnects", reconnects0 + 1), reconnects0 + 1);
  EXPECT_EQ(inbox().counter("link", "readings published as NaN (invalid)"), 0);
  expect_all_increasing();
}

TEST_F(DriverFaults, LineStallsMidPacket) {
  const long long checksum0 = inbox().counter("link", "checksum errors");
  const long long resyncs0 = inbox().counter("link", "resyncs");
  std::vector<std::uint8_t> half = encode(kT0 + 5);
  half.resize(100);
  const std::size_t before = inbox().field_count();
  port().write(half);
  inbox().wait_all_read(port());  // the driver has the half packet; the rest never comes
  // kT0 + 6 follows the lost kT0 + 5: ahead of the packet count, so held until the next packet
  // confirms it (documented 1-packet delay), then published with it; nothing is lost.
  port().write(encode(kT0 + 6));
  inbox().wait_all_read(port());  // read and handled (held)
  inbox().fresh();
  EXPECT_EQ(inbox().field_count(), before) << "a packet after a lost one is published before it is confirmed";
  std::vector<std::uint8_t> more = encode(kT0 + 7);
  append(more, encode(kT0 + 8));
  write_and_collect(more, 30);
  expect_packets(inbox().fields_from(before), {kT0 + 6, kT0 + 7, kT0 + 8});
  inbox().fresh();
  // The half packet is skipped (flushed at the read gap or resynchronised): never a packet.
  EXPECT_GE(inbox().counter("link", "checksum errors") - checksum0 + inbox().counter("link", "resyncs") - resyncs0 +
                (inbox().counter("link", "bytes skipped") > 0 ? 1 : 0),
            1);
  expect_all_increasing();
}

TEST_F(DriverFaults, BytesDroppedInsidePacket) {
  const long long resyncs0 = inbox().counter("link", "resyncs");
  const long long skipped0 = inbox().counter("link", "bytes skipped");
  std::vector<std::uint8_t> damaged = encode(kT0 + 9);
  damaged.erase(damaged.begin() + 40, damaged.begin() + 70);  // 30 bytes lost on the line
  std::vector<std::uint8_t> bytes = damaged;
  append(bytes, encode(kT0 + 10));
  append(bytes, encode(kT0 + 11));
  const auto fields = write_and_collect(bytes, 20);
  expect_packets(fields, {kT0 + 10, kT0 + 11});
  inbox().fresh();
  EXPECT_GE(inbox().wait_counter("link", "resyncs", resyncs0 + 1), resyncs0 + 1);
  EXPECT_GE(inbox().counter("link", "bytes skipped"), skipped0 + 1);
  expect_all_increasing();
}

TEST_F(DriverFaults, GarbageInsertedInsidePacket) {
  const long long resyncs0 = inbox().counter("link", "resyncs");
  std::vector<std::uint8_t> damaged = encode(kT0 + 12);
  const std::vector<std::uint8_t> noise = {0x4C, 0x30, 0xFF, 0x00, 0x4C};  // 0x4C: 'L', a header-like byte
  damaged.insert(damaged.begin() + 60, noise.begin(), noise.end());
  std::vector<std::uint8_t> bytes = damaged;
  append(bytes, encode(kT0 + 13));
  append(bytes, encode(kT0 + 14));
  const auto fields = write_and_collect(bytes, 20);
  expect_packets(fields, {kT0 + 13, kT0 + 14});
  EXPECT_GE(inbox().wait_counter("link", "resyncs", resyncs0 + 1), resyncs0 + 1);
  expect_all_increasing();
}

/// Packets kT0+first .. +2; the middle one carries a burst of 4 implausible readings (1e6 nT,
/// float garbage of a failing ADC) in x and z; the others are normal.
std::vector<mic::Lemi025Packet> packets_with_bad_burst(double first) {
  std::vector<mic::Lemi025Packet> sent;
  for (int j = 0; j < 3; ++j) {
    mic::Lemi025Packet p = make_packet(first + j);
    if (j == 1) {
      for (int k = 3; k < 7; ++k) p.variation_nT(k, k % 2 == 0 ? 0 : 2) = (k % 2 == 0 ? 1.0 : -1.0) * 1.0e6;
    }
    sent.push_back(p);
  }
  return sent;
}

// Bug A (fixed): the core parser frames packets by tag, BCD time and status bytes (and the sum8
// checksum of this driver), not by their readings; a packet whose checksum verifies is intact, so
// its 4 implausible readings are published as NaN (all three components, never a number) and
// counted, and its 6 good readings and the neighbours are published exactly. No resync.
TEST_F(DriverFaults, ImplausibleReadingsLiveAreNaN) {
  const long long invalid0 = inbox().counter("link", kInvalid);
  const long long resyncs0 = inbox().counter("link", "resyncs");
  const long long published0 = inbox().counter("link", "readings published");
  const double first = kT0 + 15;
  const auto sent = packets_with_bad_burst(first);
  std::vector<std::uint8_t> bytes;
  for (const auto& p : sent) append(bytes, encode(p));
  const auto fields = write_and_collect(bytes, 30);
  ASSERT_EQ(fields.size(), 30u);
  for (std::size_t i = 0; i < fields.size(); ++i) {
    const std::size_t j = i / 10;
    const int k = static_cast<int>(i % 10);
    EXPECT_EQ(fields[i].header.stamp, gps_stamp(first + static_cast<double>(j), k)) << "reading " << i;
    const auto& f = fields[i].magnetic_field;
    if (j == 1 && k >= 3 && k < 7) {
      EXPECT_TRUE(std::isnan(f.x) && std::isnan(f.y) && std::isnan(f.z)) << "reading " << i;
    } else {
      EXPECT_NEAR(f.x, (kBias_nT(0) + sent[j].variation_nT(k, 0)) * kNanotesla, 1e-4 * kNanotesla) << i;
      EXPECT_NEAR(f.y, (kBias_nT(1) + sent[j].variation_nT(k, 1)) * kNanotesla, 1e-4 * kNanotesla) << i;
      EXPECT_NEAR(f.z, (kBias_nT(2) + sent[j].variation_nT(k, 2)) * kNanotesla, 1e-4 * kNanotesla) << i;
    }
  }
  EXPECT_EQ(inbox().wait_counter("link", kInvalid, invalid0 + 4), invalid0 + 4);
  EXPECT_EQ(inbox().wait_counter("link", "readings published", published0 + 30), published0 + 30);
  EXPECT_EQ(inbox().counter("link", "resyncs"), resyncs0);
  expect_all_increasing();
}

TEST_F(DriverFaults, DuplicatedPacketPublishedOnce) {
  const long long dropped0 = inbox().counter("link", kDropped);
  const std::size_t mark = inbox().history_size();
  std::vector<std::uint8_t> bytes = encode(kT0 + 18);
  append(bytes, encode(kT0 + 18));  // repeated
  append(bytes, encode(kT0 + 19));
  append(bytes, encode(kT0 + 19));  // repeated
  append(bytes, encode(kT0 + 20));
  const auto fields = write_and_collect(bytes, 30);
  expect_packets(fields, {kT0 + 18, kT0 + 19, kT0 + 20});
  EXPECT_EQ(inbox().wait_counter("link", kDropped, dropped0 + 20), dropped0 + 20);
  EXPECT_TRUE(wait_for(
      [&] { return inbox().any_since(mark, "link", diagnostic_msgs::DiagnosticStatus::WARN, "readings dropped"); }))
      << "no WARN 'readings dropped' in the link diagnostics";
  expect_all_increasing();
}

TEST_F(DriverFaults, ClockJumpsForwardThenContinues) {
  const long long jumps0 = inbox().counter("link", "time jumps");
  const long long dropped0 = inbox().counter("link", kDropped);
  const long long confirmed0 = inbox().counter("link", kConfirmed);
  const long long unconfirmed0 = inbox().counter("link", kUnconfirmed);
  const double later = kT0 + 3600.0 + 21;
  std::vector<std::uint8_t> bytes = encode(kT0 + 21);
  append(bytes, encode(later));
  append(bytes, encode(later + 1));
  append(bytes, encode(later + 2));
  const auto fields = write_and_collect(bytes, 40);
  expect_packets(fields, {kT0 + 21, later, later + 1, later + 2});
  EXPECT_GE(inbox().wait_counter("link", "time jumps", jumps0 + 1), jumps0 + 1);
  EXPECT_EQ(inbox().wait_counter("link", kConfirmed, confirmed0 + 1), confirmed0 + 1);
  inbox().fresh();
  EXPECT_EQ(inbox().counter("link", kDropped), dropped0);
  EXPECT_EQ(inbox().counter("link", kUnconfirmed), unconfirmed0);
  expect_all_increasing();
}

// Bug B (fixed): a single packet whose GPS second is a day ahead but whose checksum is right (a
// GPS receiver glitch, or any corruption with checksum none) used to set the last published stamp
// a day ahead and block every correct reading for a day. Now a GPS second ahead of what the
// packets since the last accepted one allow is held until the next packet: base (itself a 1 h
// jump from the previous test) and the glitch are both held; base + 2 continues from base (one
// slot for the glitch), which confirms base and drops the glitch.
TEST_F(DriverFaults, SingleForwardGlitchDoesNotBlockData) {
  const long long unconfirmed0 = inbox().counter("link", kUnconfirmed);
  const long long dropped0 = inbox().counter("link", kDropped);
  const std::size_t mark = inbox().history_size();
  const double base = kT0 + 7200.0;
  std::vector<std::uint8_t> bytes = encode(base);
  append(bytes, encode(base + 86400.0));  // one bad GPS second
  append(bytes, encode(base + 2));
  append(bytes, encode(base + 3));
  append(bytes, encode(base + 4));
  const auto fields = write_and_collect(bytes, 40);
  expect_packets(fields, {base, base + 2, base + 3, base + 4});
  for (const auto& f : fields)
    EXPECT_LT(f.header.stamp, ros::Time(static_cast<std::uint32_t>(base + 10))) << "the glitch was published";
  EXPECT_EQ(inbox().wait_counter("link", kUnconfirmed, unconfirmed0 + 1), unconfirmed0 + 1);
  EXPECT_TRUE(wait_for(
      [&] {
        return inbox().any_since(mark, "link", diagnostic_msgs::DiagnosticStatus::WARN, "isolated GPS time jump");
      }))
      << "no WARN 'isolated GPS time jump' in the link diagnostics";
  inbox().fresh();
  EXPECT_EQ(inbox().counter("link", kDropped), dropped0) << "good readings dropped after the glitch";
  // The driver is not poisoned: the next second is published at once.
  const auto next = write_and_collect(encode(base + 5), 10);
  expect_packets(next, {base + 5});
  expect_all_increasing();
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_faults_driver");
  ros::NodeHandle nh;
  // One binary, two launch files: ~suite picks the fixture (DriverFaults: wall clock; DriverPcClock:
  // /use_sim_time). An explicit --gtest_filter wins.
  if (testing::GTEST_FLAG(filter) == "*") testing::GTEST_FLAG(filter) = param("suite", "DriverFaults") + ".*";
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const std::string link = param("link");
  if (link.empty()) {
    std::fprintf(stderr, "test_faults_driver: ~link not set\n");
    return 1;
  }
  auto port = std::make_unique<mic::test::PtyLink>(link);
  const std::string error = port->open();
  if (!error.empty()) {
    std::fprintf(stderr, "test_faults_driver: %s\n", error.c_str());
    return 1;
  }
  auto inbox = std::make_unique<Inbox>();
  g_port = port.get();
  g_inbox = inbox.get();
  const int result = RUN_ALL_TESTS();
  g_port = nullptr;
  g_inbox = nullptr;
  spinner.stop();
  return result;
}
