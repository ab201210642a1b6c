// rostest with a real master: lemi025_driver reading a pseudo-terminal that this test creates
// and writes hand-built LEMI-025 packets into (test/ros/test_lemi025_driver.test launches the
// driver on the pty's symlink, checksum sum8, frame_id lemi_under_test, noise 0.05 nT).
//
// The Lemi025DriverOnPty tests share the one driver and run in declaration order (the stamps
// the driver has published only grow, so each test uses later GPS seconds than the previous):
//   PublishesTeslaWithGpsStamps    values in T (bias + variation), stamps t_gps - 0.3 + 0.1 k to
//                                  the nanosecond, frame_id, covariance, temperatures
//   CorruptedPacketIsSkippedAndCounted  a damaged packet and garbage bytes: skipped, counted; the
//                                  packet after the lost second is published once the next
//                                  packet confirms its time (the driver's 1-packet delay)
//   TimeJumpBackwardsIsDropped     the clock steps back: nothing published goes backwards
//   SerialDisconnectIsSurvived     the pty is unplugged (link removed, pty closed), a new pty
//                                  appears under the symlink
//   LinkRepointedWhileOldPtyStaysOpen  the symlink names a new pty while the old stays open
//   GpsNotActiveUsesPcTime         GPS status 'P': PC-clock stamps and a diagnostic warning;
//                                  back to 'A': GPS stamps again
//   BiasChangeIsReported           the bias (compensation) field changes: counted, WARN
// Other tests of the same binary: Lemi025DriverRecordings.* (test_lemi025_driver_recordings.cpp),
// Lemi025DriverParameters.* (test_lemi025_driver_parameters.cpp), both run from
// test_lemi025_driver.test too; SimulatedStation.* and SimulatedNetwork.* (test_simulated_station.cpp)
// run from test_simulated_station.test and test_simulated_network.test. main() is here.
#include "magnetometer_insitu_calibration/formats/lemi025_packet.hpp"
#include "driver_test_support.hpp"
#include "lemi025_test_packets.hpp"
#include "pty_link.hpp"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/Temperature.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

using mic::test::encode;
using mic::test::gps_stamp;
using mic::test::kBias_nT;
using mic::test::kNanotesla;
using mic::test::kT0;
using mic::test::make_packet;
using mic::test::param;
using mic::test::wait_for;

// ---- What the driver publishes -----------------------------------------------------------------

/// Readings (FieldInbox), temperatures, and diagnostics (DriverDiagnostics).
class Inbox : public mic::test::DriverInbox {
 public:
  Inbox() : DriverInbox(param("driver_namespace", "/lemi"), param("driver_node_name", "lemi_driver")) {
    ros::NodeHandle nh;
    const std::string ns = param("driver_namespace", "/lemi");
    sensor_sub_ = nh.subscribe(ns + "/temperature/sensor", 1000, &Inbox::on_sensor, this);
    electronics_sub_ = nh.subscribe(ns + "/temperature/electronics", 1000, &Inbox::on_electronics, this);
  }

  bool connected() const {
    return fields_connected() && sensor_sub_.getNumPublishers() > 0 && electronics_sub_.getNumPublishers() > 0;
  }
  std::size_t temperature_count() {
    std::lock_guard<std::mutex> lock(mutex_);
    return std::min(sensor_.size(), electronics_.size());
  }
  std::vector<sensor_msgs::Temperature> sensor_from(std::size_t first) {
    std::lock_guard<std::mutex> lock(mutex_);
    return std::vector<sensor_msgs::Temperature>(sensor_.begin() + static_cast<std::ptrdiff_t>(first), sensor_.end());
  }
  std::vector<sensor_msgs::Temperature> electronics_from(std::size_t first) {
    std::lock_guard<std::mutex> lock(mutex_);
    return std::vector<sensor_msgs::Temperature>(electronics_.begin() + static_cast<std::ptrdiff_t>(first),
                                                 electronics_.end());
  }

 private:
  void on_sensor(const sensor_msgs::Temperature::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    sensor_.push_back(*m);
  }
  void on_electronics(const sensor_msgs::Temperature::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    electronics_.push_back(*m);
  }

  std::mutex mutex_;
  std::vector<sensor_msgs::Temperature> sensor_, electronics_;
  ros::Subscriber sensor_sub_, electronics_sub_;
};

// One pty and one inbox for the whole run (the driver of the .test file keeps running).
mic::test::PtyLink* g_port = nullptr;
Inbox* g_inbox = nullptr;

class Lemi025DriverOnPty : public testing::Test {
 protected:
  void SetUp() override {
    ASSERT_NE(g_port, nullptr);
    mic::test::assert_driver_on_pty([] { return g_inbox->connected(); }, *g_inbox);
  }
  mic::test::PtyLink& port() { return *g_port; }
  Inbox& inbox() { return *g_inbox; }

  /// Writes packets of the given GPS seconds and waits for their 10 readings each.
  std::vector<sensor_msgs::MagneticField> send(const std::vector<double>& seconds, std::size_t expected_readings,
                                               char gps_status = 'A') {
    std::vector<std::uint8_t> bytes;
    for (double s : seconds) {
      const auto packet = encode(make_packet(s, gps_status));
      bytes.insert(bytes.end(), packet.begin(), packet.end());
    }
    return inbox().write_and_collect(port(), bytes, expected_readings);
  }

  static void expect_all_stamps_increasing() { g_inbox->expect_all_stamps_increasing(); }
};

TEST_F(Lemi025DriverOnPty, PublishesTeslaWithGpsStamps) {
  const std::size_t temperatures_before = inbox().temperature_count();
  const std::vector<double> seconds = {kT0, kT0 + 1, kT0 + 2};
  const auto fields = send(seconds, 30);
  ASSERT_EQ(fields.size(), 30u);
  ASSERT_TRUE(wait_for([&] { return inbox().temperature_count() >= temperatures_before + 3; }));
  const double variance = std::pow(std::stod(param("noise_nT", "0.05")) * kNanotesla, 2);
  for (std::size_t p = 0; p < seconds.size(); ++p) {
    const mic::Lemi025Packet sent = make_packet(seconds[p]);
    // What the packet holds after float32 (uT) encoding: the driver must publish exactly this.
    const mic::Lemi025Packet decoded = mic::decode_lemi025_packet(encode(sent).data(), mic::ChecksumMode::kSum8);
    for (int k = 0; k < 10; ++k) {
      const sensor_msgs::MagneticField& m = fields[10 * p + static_cast<std::size_t>(k)];
      SCOPED_TRACE("packet " + std::to_string(p) + " reading " + std::to_string(k));
      EXPECT_EQ(m.header.stamp, gps_stamp(seconds[p], k));  // to the nanosecond
      EXPECT_NEAR(m.header.stamp.toSec(), sent.gps_time_s - 0.3 + 0.1 * k, 1e-6);
      EXPECT_EQ(m.header.frame_id, param("frame_id", "lemi_under_test"));
      const double got[3] = {m.magnetic_field.x, m.magnetic_field.y, m.magnetic_field.z};
      for (int c = 0; c < 3; ++c) {
        // full field = bias + variation, 1 nT = 1e-9 T; the hand-built values to float32 precision
        EXPECT_NEAR(got[c], (kBias_nT(c) + sent.variation_nT(k, c)) * kNanotesla, 1e-4 * kNanotesla);
        EXPECT_NEAR(got[c], (decoded.bias_nT(c) + decoded.variation_nT(k, c)) * kNanotesla, 1e-9 * kNanotesla);
      }
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
          EXPECT_DOUBLE_EQ(m.magnetic_field_covariance[static_cast<std::size_t>(3 * r + c)], r == c ? variance : 0.0);
        }
      }
    }
  }
  const auto sensor = inbox().sensor_from(temperatures_before);
  const auto electronics = inbox().electronics_from(temperatures_before);
  ASSERT_EQ(sensor.size(), 3u);
  ASSERT_EQ(electronics.size(), 3u);
  for (std::size_t p = 0; p < 3; ++p) {
    const mic::Lemi025Packet sent = make_packet(seconds[p]);
    EXPECT_EQ(sensor[p].header.stamp, gps_stamp(seconds[p], 0));
    EXPECT_EQ(electronics[p].header.stamp, gps_stamp(seconds[p], 0));
    EXPECT_EQ(sensor[p].header.frame_id, param("frame_id", "lemi_under_test"));
    EXPECT_NEAR(sensor[p].temperature, sent.sensor_temperature_C, 0.0051);  // 0.01 degC resolution
    EXPECT_NEAR(electronics[p].temperature, sent.electronics_temperature_C, 0.0051);
  }
  // Diagnostics: instrument state as sent.
  EXPECT_TRUE(wait_for([&] { return inbox().value("instrument", "supply voltage (V)") == "12.3"; }));
  EXPECT_EQ(inbox().value("instrument", "bias field X Y Z (nT)"), "21500 502.5 43000");
  EXPECT_EQ(inbox().value("instrument", "time source"), "GPS");
  EXPECT_EQ(inbox().value("instrument", "station"), "7");
  expect_all_stamps_increasing();
}

TEST_F(Lemi025DriverOnPty, CorruptedPacketIsSkippedAndCounted) {
  ASSERT_GE(inbox().wait_counter("link", "packets", 3), 3);
  const long long checksum0 = inbox().counter("link", "checksum errors");
  const long long resyncs0 = inbox().counter("link", "resyncs");
  const long long skipped0 = inbox().counter("link", "bytes skipped");
  const std::size_t before = inbox().field_count();

  std::vector<std::uint8_t> bytes = encode(make_packet(kT0 + 3));
  const std::vector<std::uint8_t> garbage(20, 0xAA);  // line noise between two packets
  bytes.insert(bytes.end(), garbage.begin(), garbage.end());
  std::vector<std::uint8_t> damaged = encode(make_packet(kT0 + 4));
  damaged[12] ^= 0x10;  // sensor temperature byte: still a packet, checksum wrong
  bytes.insert(bytes.end(), damaged.begin(), damaged.end());
  // kT0 + 5 comes after a lost second: the driver holds it until kT0 + 6 confirms its time.
  for (double s : {kT0 + 5, kT0 + 6}) {
    const auto good = encode(make_packet(s));
    bytes.insert(bytes.end(), good.begin(), good.end());
  }
  port().write(bytes);

  ASSERT_TRUE(wait_for([&] { return inbox().field_count() >= before + 30; }));
  inbox().wait_all_read(port());  // anything extra would be here now
  const auto fields = inbox().fields_from(before);
  ASSERT_EQ(fields.size(), 30u) << "the damaged packet must not be published";
  for (int k = 0; k < 10; ++k) {
    EXPECT_EQ(fields[static_cast<std::size_t>(k)].header.stamp, gps_stamp(kT0 + 3, k));
    EXPECT_EQ(fields[static_cast<std::size_t>(10 + k)].header.stamp, gps_stamp(kT0 + 5, k));
    EXPECT_EQ(fields[static_cast<std::size_t>(20 + k)].header.stamp, gps_stamp(kT0 + 6, k));
  }
  EXPECT_EQ(inbox().wait_counter("link", "checksum errors", checksum0 + 1), checksum0 + 1);
  EXPECT_EQ(inbox().wait_counter("link", "resyncs", resyncs0 + 1), resyncs0 + 1);
  EXPECT_EQ(inbox().wait_counter("link", "bytes skipped", skipped0 + 20), skipped0 + 20);
  expect_all_stamps_increasing();
}

TEST_F(Lemi025DriverOnPty, TimeJumpBackwardsIsDropped) {
  ASSERT_GE(inbox().wait_counter("link", "packets", 6), 6);
  const long long dropped0 = inbox().counter("link", "readings dropped (stamp not after the previous)");
  const long long jumps0 = inbox().counter("link", "time jumps");
  // 7, 8, then the clock steps back 28 s (-20, -19), then 9: only 7, 8, 9 are published.
  const auto fields = send({kT0 + 7, kT0 + 8, kT0 - 20, kT0 - 19, kT0 + 9}, 30);
  ASSERT_EQ(fields.size(), 30u);
  const double expected[3] = {kT0 + 7, kT0 + 8, kT0 + 9};
  for (std::size_t i = 0; i < fields.size(); ++i) {
    EXPECT_EQ(fields[i].header.stamp, gps_stamp(expected[i / 10], static_cast<int>(i % 10)));
  }
  EXPECT_EQ(inbox().wait_counter("link", "readings dropped (stamp not after the previous)", dropped0 + 20),
            dropped0 + 20);
  EXPECT_GE(inbox().wait_counter("link", "time jumps", jumps0 + 2), jumps0 + 2);  // back, then forward
  expect_all_stamps_increasing();
}

TEST_F(Lemi025DriverOnPty, SerialDisconnectIsSurvived) {
  const long long disconnects0 = inbox().counter("link", "disconnects");
  const long long reconnects0 = inbox().counter("link", "reconnects");
  port().close();  // unplugged
  EXPECT_TRUE(wait_for([&] { return inbox().value("link", "connected") == "False"; }));
  diagnostic_msgs::DiagnosticStatus link;
  ASSERT_TRUE(inbox().status("link", link));
  EXPECT_EQ(link.level, diagnostic_msgs::DiagnosticStatus::ERROR) << link.message;
  EXPECT_NE(link.message.find("disconnected"), std::string::npos) << link.message;
  EXPECT_EQ(inbox().wait_counter("link", "disconnects", disconnects0 + 1), disconnects0 + 1);
  // Visible while it lasts: why (the link is gone) and the reopen attempts, one every 0.2 s.
  EXPECT_GE(inbox().wait_counter("link", "reopen attempts", inbox().counter("link", "reopen attempts") + 2), 2);
  EXPECT_NE(inbox().value("link", "connection problem").find("No such file"), std::string::npos)
      << inbox().value("link", "connection problem");

  ASSERT_EQ(port().open(), "");  // plugged in again: a new pty under the same symlink
  const auto fields = send({kT0 + 10, kT0 + 11, kT0 + 12}, 30);
  ASSERT_EQ(fields.size(), 30u) << "no data after the reconnection";
  EXPECT_EQ(fields.front().header.stamp, gps_stamp(kT0 + 10, 0));
  EXPECT_EQ(fields.back().header.stamp, gps_stamp(kT0 + 12, 9));
  EXPECT_GE(inbox().wait_counter("link", "reconnects", reconnects0 + 1), reconnects0 + 1);
  EXPECT_EQ(inbox().counter("link", "disconnects"), disconnects0 + 1);
  EXPECT_EQ(inbox().value("link", "connected"), "True");
  expect_all_stamps_increasing();
}

// The link is re-pointed at a new pty while the old one stays open and silent: socat, ser2net or
// a simulator re-created its pty; or (a flaky failure once seen) the stale link of an
// unplugged pty named a pty number the kernel had given to another test's pty, the driver opened
// that one, and then the instrument's new pty replaced the link. The driver must follow the link
// (it used to stay on the old pty until that one closed: 24 s without data).
TEST_F(Lemi025DriverOnPty, LinkRepointedWhileOldPtyStaysOpen) {
  const long long disconnects0 = inbox().counter("link", "disconnects");
  const long long reconnects0 = inbox().counter("link", "reconnects");
  ASSERT_EQ(port().replace(), "");
  const auto fields = send({kT0 + 13, kT0 + 14, kT0 + 15}, 30);
  ASSERT_EQ(fields.size(), 30u) << "no data from the pty the link names now";
  EXPECT_EQ(fields.front().header.stamp, gps_stamp(kT0 + 13, 0));
  EXPECT_EQ(fields.back().header.stamp, gps_stamp(kT0 + 15, 9));
  EXPECT_EQ(inbox().wait_counter("link", "disconnects", disconnects0 + 1), disconnects0 + 1);
  EXPECT_EQ(inbox().wait_counter("link", "reconnects", reconnects0 + 1), reconnects0 + 1);
  EXPECT_NE(inbox().value("link", "last disconnect").find("now names another device"), std::string::npos)
      << inbox().value("link", "last disconnect");
  expect_all_stamps_increasing();
}

TEST_F(Lemi025DriverOnPty, GpsNotActiveUsesPcTime) {
  // Three packets without GPS fix, one per second like the instrument. Their GPS seconds (2024)
  // must not be used: the stamps come from the PC clock at arrival (last reading = arrival).
  const std::size_t before = inbox().field_count();
  std::vector<double> written_s, received_s;  // PC clock (ROS time, s) before the write, after the readings
  for (int j = 0; j < 3; ++j) {
    if (j > 0) ros::WallDuration(1.0).sleep();  // the instrument's pace (the stimulus, not a wait)
    written_s.push_back(ros::Time::now().toSec());
    port().write(encode(make_packet(kT0 + 12 + j, 'P')));
    ASSERT_TRUE(wait_for([&] { return inbox().field_count() >= before + 10 * static_cast<std::size_t>(j + 1); }));
    received_s.push_back(ros::Time::now().toSec());
  }
  const auto fields = inbox().fields_from(before);
  ASSERT_EQ(fields.size(), 30u);
  for (std::size_t j = 0; j < 3; ++j) {
    const double first = fields[10 * j].header.stamp.toSec();
    // The driver took the arrival time between the write and the readings' arrival here; its
    // stamp (arrival - 0.9 s) is slewed from the 1 s prediction by at most 0.45 s. Bounds, not a
    // latency: a busy machine cannot break this.
    EXPECT_GE(first + 0.9, written_s[j] - 0.5) << "packet " << j;
    EXPECT_LE(first + 0.9, received_s[j] + 0.5) << "packet " << j;
    EXPECT_GT(std::abs(first - (kT0 + 12 + static_cast<double>(j))), 86400.0) << "GPS time used";
    for (std::size_t k = 1; k < 10; ++k) {
      EXPECT_NEAR((fields[10 * j + k].header.stamp - fields[10 * j + k - 1].header.stamp).toSec(), 0.1, 1e-6);
    }
  }
  EXPECT_TRUE(wait_for([&] { return inbox().value("instrument", "GPS status").rfind("P", 0) == 0; }));
  diagnostic_msgs::DiagnosticStatus instrument;
  ASSERT_TRUE(inbox().status("instrument", instrument));
  EXPECT_EQ(instrument.level, diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_NE(instrument.message.find("GPS status P"), std::string::npos) << instrument.message;
  EXPECT_NE(instrument.message.find("PC clock"), std::string::npos) << instrument.message;
  EXPECT_NE(inbox().value("instrument", "time source").find("PC clock"), std::string::npos);
  EXPECT_GE(inbox().wait_counter("instrument", "packets without GPS", 3), 3);

  // GPS fix again (its time is now ahead of the PC-clock stamps): GPS stamps, diagnostics OK.
  const double gps = std::floor(ros::Time::now().toSec()) + 10.0;
  const auto again = send({gps, gps + 1}, 20);
  ASSERT_EQ(again.size(), 20u);
  EXPECT_EQ(again.front().header.stamp, gps_stamp(gps, 0));
  EXPECT_TRUE(wait_for([&] { return inbox().value("instrument", "time source") == "GPS"; }));
  EXPECT_TRUE(wait_for(
      [&] { return inbox().status("instrument", instrument) && instrument.level == diagnostic_msgs::DiagnosticStatus::OK; }))
      << instrument.message;
  expect_all_stamps_increasing();
}

TEST_F(Lemi025DriverOnPty, BiasChangeIsReported) {
  const long long changes0 = inbox().counter("instrument", "bias changes");
  ASSERT_GE(changes0, 0);
  const double gps = std::floor(ros::Time::now().toSec()) + 20.0;
  mic::Lemi025Packet changed = make_packet(gps + 1);
  changed.bias_nT(2) += 250.0;  // the compensation field re-set on Z
  std::vector<std::uint8_t> bytes = encode(make_packet(gps));
  const auto second = encode(changed);
  bytes.insert(bytes.end(), second.begin(), second.end());
  const std::size_t before = inbox().field_count();
  port().write(bytes);
  ASSERT_TRUE(wait_for([&] { return inbox().field_count() >= before + 20; }));
  const auto fields = inbox().fields_from(before);
  // Full field continues through the re-set: bias + variation.
  EXPECT_NEAR(fields[10].magnetic_field.z, (kBias_nT(2) + 250.0 + changed.variation_nT(0, 2)) * kNanotesla,
              1e-4 * kNanotesla);
  EXPECT_EQ(inbox().wait_counter("instrument", "bias changes", changes0 + 1), changes0 + 1);
  diagnostic_msgs::DiagnosticStatus instrument;
  EXPECT_TRUE(wait_for(
      [&] {
        return inbox().status("instrument", instrument) && instrument.level == diagnostic_msgs::DiagnosticStatus::WARN &&
               instrument.message.find("bias field changed") != std::string::npos;
      }))
      << instrument.message;
  EXPECT_NE(inbox().value("instrument", "last bias change").find("21500 502.5 43000 -> 21500 502.5 43250"),
            std::string::npos)
      << inbox().value("instrument", "last bias change");
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_lemi025_driver");
  ros::NodeHandle nh;
  ros::AsyncSpinner spinner(2);
  spinner.start();
  std::unique_ptr<mic::test::PtyLink> port;
  std::unique_ptr<Inbox> inbox;
  const std::string link = param("link");
  if (!link.empty()) {  // the driver tests: the .test file names the symlink the driver reads
    port = std::make_unique<mic::test::PtyLink>(link);
    const std::string error = port->open();
    if (!error.empty()) {
      std::fprintf(stderr, "test_lemi025_driver: %s\n", error.c_str());
      return 1;
    }
    inbox = std::make_unique<Inbox>();
    g_port = port.get();
    g_inbox = inbox.get();
  }
  const int result = RUN_ALL_TESTS();
  g_port = nullptr;
  g_inbox = nullptr;
  spinner.stop();
  return result;
}
