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
//   SerialDisconnectIsSurvived     the pty master closes, a new pty appears under the symlink
//   GpsNotActiveUsesPcTime         GPS status 'P': PC-clock stamps and a diagnostic warning;
//                                  back to 'A': GPS stamps again
//   BiasChangeIsReported           the bias (compensation) field changes: counted, WARN
// Lemi025DriverRecordings.* start the driver themselves on recordings written here:
//   CompactFlashInvalidReadingsAreNaN  a card image with a non-finite and an implausible reading:
//                                      published as NaN, the others as recorded
//   LemiBinWithoutGpsUsesRecordedPcTime  LemiBin records with GPS status 'P': stamped from the
//                                      PC time stored in each record
//   StreamFileGpsGlitchDroppedAndLastHeldPacketReleased  a stream recording with a day-ahead GPS
//                                      second (dropped) and a final jump (held, then published at
//                                      the end of the recording)
//   StreamFileFirstPacketGlitchDoesNotBlockData  the first packet a day ahead: dropped, the rest
//                                      published
// Lemi025DriverParameters.BadParametersExitNonZero starts the driver itself with impossible
// parameters and checks the exit code and the fatal message naming the parameter.
// SimulatedStation.* (test_simulated_station.cpp) runs from test_simulated_station.test.
#include "magnetometer_insitu_calibration/formats/lemi025_packet.hpp"
#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"
#include "driver_test_support.hpp"
#include "pty_link.hpp"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/Temperature.h>

#include <stdlib.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

constexpr double kNanotesla = 1e-9;  // T
constexpr double kT0 = 1709251200.0;  // 2024-03-01T00:00:00Z: GPS time of the first packet
const Eigen::Vector3d kBias_nT(21500.0, 502.5, 43000.0);  // multiples of 2.5 nT

using mic::test::encode;
using mic::test::gps_stamp;
using mic::test::param;
using mic::test::wait_for;

// ---- Packets ------------------------------------------------------------------------------------

/// A packet with known values: bias kBias_nT, reading k component c = (c + 1) * 10 + 0.5 k +
/// 0.25 * (gps - kT0) nT (modulo 100), temperatures depending on the second.
mic::Lemi025Packet make_packet(double gps_s, char gps_status = 'A') {
  mic::Lemi025Packet p;
  p.station = 7;
  p.gps_time_s = gps_s;
  const double i = std::fmod(gps_s - kT0, 40.0);
  p.sensor_temperature_C = 21.37 + 0.01 * i;
  p.electronics_temperature_C = 30.5 - 0.02 * i;
  p.dac_counts = {{100, -200, 300}};
  p.bias_nT = kBias_nT;
  for (int k = 0; k < mic::kLemi025ReadingsPerPacket; ++k) {
    for (int c = 0; c < 3; ++c) p.variation_nT(k, c) = (c + 1) * 10.0 + 0.5 * k + 0.25 * i - 5.0 * c * c;
  }
  p.mode = 2;
  p.flash_free_percent = 77;
  p.supply_V = 12.3;
  p.gps_status = gps_status;
  return p;
}

// ---- What the driver publishes -----------------------------------------------------------------

/// Readings (FieldInbox), temperatures, and diagnostics (DriverDiagnostics).
class Inbox : public mic::test::FieldInbox, public mic::test::DriverDiagnostics {
 public:
  Inbox()
      : FieldInbox(param("driver_namespace", "/lemi")), DriverDiagnostics(param("driver_node_name", "lemi_driver")) {
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
  ASSERT_TRUE(wait_for([&] { return inbox().temperature_count() >= temperatures_before + 3; }, 5.0));
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
  EXPECT_TRUE(wait_for([&] { return inbox().value("instrument", "supply voltage (V)") == "12.3"; }, 5.0));
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

  ASSERT_TRUE(wait_for([&] { return inbox().field_count() >= before + 30; }, 10.0));
  ros::WallDuration(0.3).sleep();
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
  EXPECT_TRUE(wait_for([&] { return inbox().value("link", "connected") == "False"; }, 10.0));
  diagnostic_msgs::DiagnosticStatus link;
  ASSERT_TRUE(inbox().status("link", link));
  EXPECT_EQ(link.level, diagnostic_msgs::DiagnosticStatus::ERROR) << link.message;
  EXPECT_NE(link.message.find("disconnected"), std::string::npos) << link.message;
  EXPECT_EQ(inbox().wait_counter("link", "disconnects", disconnects0 + 1), disconnects0 + 1);

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

TEST_F(Lemi025DriverOnPty, GpsNotActiveUsesPcTime) {
  // Three packets without GPS fix, one per second like the instrument. Their GPS seconds (2024)
  // must not be used: the stamps come from the PC clock at arrival (last reading = arrival).
  const std::size_t before = inbox().field_count();
  std::vector<double> written_s;
  for (int j = 0; j < 3; ++j) {
    if (j > 0) ros::WallDuration(1.0).sleep();
    written_s.push_back(ros::Time::now().toSec());
    port().write(encode(make_packet(kT0 + 12 + j, 'P')));
  }
  ASSERT_TRUE(wait_for([&] { return inbox().field_count() >= before + 30; }, 10.0));
  const auto fields = inbox().fields_from(before);
  ASSERT_EQ(fields.size(), 30u);
  for (std::size_t j = 0; j < 3; ++j) {
    const double first = fields[10 * j].header.stamp.toSec();
    // Arrival within ~0.3 s of the write; the PC clock slews by at most 0.5 s.
    EXPECT_NEAR(first + 0.9, written_s[j], 0.8) << "packet " << j;
    EXPECT_GT(std::abs(first - (kT0 + 12 + static_cast<double>(j))), 86400.0) << "GPS time used";
    for (std::size_t k = 1; k < 10; ++k) {
      EXPECT_NEAR((fields[10 * j + k].header.stamp - fields[10 * j + k - 1].header.stamp).toSec(), 0.1, 1e-6);
    }
  }
  EXPECT_TRUE(wait_for([&] { return inbox().value("instrument", "GPS status").rfind("P", 0) == 0; }, 5.0));
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
  EXPECT_TRUE(wait_for([&] { return inbox().value("instrument", "time source") == "GPS"; }, 5.0));
  EXPECT_TRUE(wait_for(
      [&] { return inbox().status("instrument", instrument) && instrument.level == diagnostic_msgs::DiagnosticStatus::OK; },
      5.0))
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
  ASSERT_TRUE(wait_for([&] { return inbox().field_count() >= before + 20; }, 10.0));
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
      },
      5.0))
      << instrument.message;
  EXPECT_NE(inbox().value("instrument", "last bias change").find("21500 502.5 43000 -> 21500 502.5 43250"),
            std::string::npos)
      << inbox().value("instrument", "last bias change");
}

// ---- Recordings (the test starts the driver itself) -----------------------------------------------

std::string driver_path() {
  char self[4096] = {0};
  const ssize_t n = ::readlink("/proc/self/exe", self, sizeof(self) - 1);
  const std::string exe = n > 0 ? std::string(self, static_cast<std::size_t>(n)) : std::string();
  return exe.substr(0, exe.rfind('/')) + "/lemi025_driver";  // catkin puts both in devel/lib/<package>
}

/// lemi025_driver in namespace `ns` with command-line private parameters; SIGINT on destruction.
class DriverProcess {
 public:
  DriverProcess(const std::string& ns, const std::vector<std::string>& parameters) {
    std::vector<std::string> args = {driver_path(), "__name:=replay", "__ns:=" + ns};
    args.insert(args.end(), parameters.begin(), parameters.end());
    pid_ = ::fork();
    if (pid_ == 0) {
      std::vector<char*> argv;
      for (std::string& a : args) argv.push_back(&a[0]);
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
  }
  ~DriverProcess() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGINT);
    int status = 0;
    for (int i = 0; i < 500 && ::waitpid(pid_, &status, WNOHANG) == 0; ++i) ::usleep(10000);
    if (::waitpid(pid_, &status, WNOHANG) == 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, &status, 0);
    }
  }
  bool started() const { return pid_ > 0; }

 private:
  pid_t pid_ = -1;
};

std::string temporary_path(const std::string& stem) {
  const char* home = std::getenv("ROS_HOME");
  return std::string(home ? home : "/tmp") + "/" + stem + "_" + std::to_string(::getpid());
}

TEST(Lemi025DriverRecordings, CompactFlashInvalidReadingsAreNaN) {
  // 10 blocks of 3 s; in the last one reading 4 is NaN and reading 7 is 1e30 nT (garbage).
  const std::string path = temporary_path("lemi025_driver_test_flash.bin");
  const double t0 = 1709251200.0 + 86400.0;
  std::vector<mic::LemiFlashBlock> blocks;
  {
    std::ofstream out(path, std::ios::binary);
    for (int b = 0; b < 10; ++b) {
      mic::LemiFlashBlock block;
      block.station = 3;
      block.time_s = t0 + 3.0 * b;
      block.gps_status = 'A';
      block.supply_V = 12.0;
      block.bias_nT = kBias_nT;
      for (int j = 0; j < mic::kLemiFlashReadingsPerBlock; ++j) {
        for (int c = 0; c < 3; ++c) block.variation_nT(j, c) = 3.0 * c + 0.5 * j + b;
        block.sensor_temperature_C(j) = 20.0;
        block.electronics_temperature_C(j) = 25.0;
      }
      if (b == 9) {
        block.variation_nT(4, 1) = std::numeric_limits<double>::quiet_NaN();
        block.variation_nT(7, 2) = 1e30;
      }
      const auto bytes = mic::encode_lemi_flash_block(block);
      out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
      blocks.push_back(block);
    }
  }
  const std::string ns = "/replay_flash";
  mic::test::FieldInbox recorder(ns);
  DriverProcess driver(ns, {"_source:=compact_flash", "_file:=" + path, "_rate:=10.0", "_frame_id:=flash"});
  ASSERT_TRUE(driver.started());
  // The last block's readings come last: wait for its final reading.
  const ros::Time last_stamp = gps_stamp(t0 + 29.0, 9);
  ASSERT_TRUE(wait_for(
      [&] {
        const auto f = recorder.all_fields();
        return !f.empty() && f.back().header.stamp >= last_stamp;
      },
      20.0))
      << recorder.field_count() << " readings";
  const auto fields = recorder.all_fields();
  std::size_t nan_readings = 0, checked = 0;
  for (const auto& m : fields) {
    // Reading j of block b: caption time + 0.1 j - 0.3 s.
    const double offset = m.header.stamp.toSec() + 0.3 - t0;
    const auto index = static_cast<int>(std::lround(offset * 10.0));
    ASSERT_NEAR(offset * 10.0, index, 1e-3);
    const int b = index / 30, j = index % 30;
    ASSERT_GE(b, 0);
    ASSERT_LT(b, 10);
    const double got[3] = {m.magnetic_field.x, m.magnetic_field.y, m.magnetic_field.z};
    const bool invalid = b == 9 && (j == 4 || j == 7);
    for (int c = 0; c < 3; ++c) {
      if (invalid) {
        EXPECT_TRUE(std::isnan(got[c])) << "block " << b << " reading " << j;
      } else {
        EXPECT_NEAR(got[c], (kBias_nT(c) + blocks[static_cast<std::size_t>(b)].variation_nT(j, c)) * kNanotesla,
                    1e-4 * kNanotesla);
      }
    }
    nan_readings += invalid;
    ++checked;
  }
  EXPECT_EQ(nan_readings, 2u) << "both invalid readings published, as NaN";
  EXPECT_GE(checked, 30u);
  ::unlink(path.c_str());
}

TEST(Lemi025DriverRecordings, LemiBinWithoutGpsUsesRecordedPcTime) {
  // 20 records; the last 10 have GPS status 'P' and a PC clock one hour ahead of the GPS seconds.
  const std::string path = temporary_path("lemi025_driver_test.lemibin");
  const double t0 = 1709251200.0 + 2 * 86400.0;
  std::vector<mic::LemiBinRecord> records;
  for (int i = 0; i < 20; ++i) {
    mic::LemiBinRecord r;
    const bool passive = i >= 10;
    r.packet = make_packet(t0 + i, passive ? 'P' : 'A');
    r.pc_time_s = t0 + i + (passive ? 3600.0 : 0.0) + 0.75;  // arrival 0.75 s after the GPS second
    records.push_back(r);
  }
  mic::write_lemi_bin(path, records, "LEMI025TEST", mic::ChecksumMode::kNone);
  const std::string ns = "/replay_lemibin";
  mic::test::FieldInbox recorder(ns);
  DriverProcess driver(ns, {"_source:=lemibin", "_file:=" + path, "_rate:=10.0"});
  ASSERT_TRUE(driver.started());
  ASSERT_TRUE(wait_for(
      [&] {
        const auto f = recorder.all_fields();
        return !f.empty() && f.back().header.stamp.toSec() > t0 + 3600.0 + 19.0;
      },
      20.0))
      << recorder.field_count() << " readings";
  const auto fields = recorder.all_fields();
  std::size_t passive_readings = 0;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    if (i > 0) EXPECT_GT(fields[i].header.stamp, fields[i - 1].header.stamp);
    const double t = fields[i].header.stamp.toSec();
    if (t < t0 + 3000.0) {  // GPS active: GPS time - 0.3 s + 0.1 k
      const double k = std::fmod(t - t0 + 0.3, 1.0) * 10.0;
      EXPECT_NEAR(k, std::round(k), 1e-4) << "stamp " << t - t0;
    } else {  // PC time of reception (= last reading): first reading 0.9 s before it
      const double since = t - (t0 + 3600.0 + 0.75 - 0.9);
      const double k = std::fmod(since, 1.0) * 10.0;
      EXPECT_NEAR(k, std::round(k), 1e-4) << "stamp " << since;
      EXPECT_GE(since, 10.0 - 1e-6);
      ++passive_readings;
    }
  }
  EXPECT_EQ(passive_readings, 100u);
  ::unlink(path.c_str());
}

/// Writes packets of the given GPS seconds (GPS 'A', sum8) back to back: a raw stream recording.
void write_stream_recording(const std::string& path, const std::vector<double>& seconds) {
  std::ofstream out(path, std::ios::binary);
  for (double s : seconds) {
    const auto bytes = encode(make_packet(s));
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  }
}

/// Waits (wall time) until the newest reading in `inbox` is stamped at or after `stamp`.
bool wait_for_stamp(mic::test::FieldInbox& inbox, const ros::Time& stamp, double timeout_s) {
  return wait_for(
      [&] {
        const auto f = inbox.all_fields();
        return !f.empty() && f.back().header.stamp >= stamp;
      },
      timeout_s);
}

// A raw stream recording (~source stream_file) through the driver's GPS-time screening: a packet
// whose GPS second is a day ahead (in the slot of t0 + 2) is dropped, the seconds around it are
// published; the last packet jumps 46 s ahead and has no later packet to confirm it: it is held,
// then published at the end of the recording. 4 lead packets (2 s at rate 2) let the subscription
// connect; from t0 on every reading is checked against the truth.
TEST(Lemi025DriverRecordings, StreamFileGpsGlitchDroppedAndLastHeldPacketReleased) {
  const std::string path = temporary_path("lemi025_driver_test_glitch.stream");
  const double t0 = 1709251200.0 + 3 * 86400.0;
  write_stream_recording(path, {t0 - 4, t0 - 3, t0 - 2, t0 - 1, t0, t0 + 1, t0 + 86400.0, t0 + 3, t0 + 4, t0 + 50});
  const std::string ns = "/replay_glitch";
  mic::test::FieldInbox recorder(ns);
  DriverProcess driver(ns, {"_source:=stream_file", "_file:=" + path, "_rate:=2.0", "_frame_id:=glitch"});
  ASSERT_TRUE(driver.started());
  ASSERT_TRUE(wait_for_stamp(recorder, gps_stamp(t0 + 50, 9), 30.0))
      << recorder.field_count() << " readings; the held last packet was not released at the end";
  ros::WallDuration(0.3).sleep();
  const auto fields = recorder.all_fields();
  std::vector<sensor_msgs::MagneticField> from_t0;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    if (i > 0) {
      EXPECT_GT(fields[i].header.stamp, fields[i - 1].header.stamp) << "reading " << i;
    }
    EXPECT_LT(fields[i].header.stamp, gps_stamp(t0 + 51, 0)) << "the day-ahead glitch was published";
    if (fields[i].header.stamp >= gps_stamp(t0, 0)) from_t0.push_back(fields[i]);
  }
  const std::vector<double> truth = {t0, t0 + 1, t0 + 3, t0 + 4, t0 + 50};
  ASSERT_EQ(from_t0.size(), 10 * truth.size());
  for (std::size_t i = 0; i < from_t0.size(); ++i) {
    const double s = truth[i / 10];
    const int k = static_cast<int>(i % 10);
    EXPECT_EQ(from_t0[i].header.stamp, gps_stamp(s, k)) << "reading " << i;
    EXPECT_NEAR(from_t0[i].magnetic_field.y, (kBias_nT(1) + make_packet(s).variation_nT(k, 1)) * kNanotesla,
                1e-4 * kNanotesla)
        << "reading " << i;
  }
  ::unlink(path.c_str());
}

// The FIRST packet of a recording carries a day-ahead GPS second (a receiver glitch at start-up):
// it has no reference to be checked against, so it is held like any jump and dropped when the
// packets after it run on from each other. Before, it became the reference and every later
// packet was "backwards": nothing was published until real time caught up. From t0 + 4 on (the
// subscription connects during the first seconds at rate 2) every reading must arrive.
TEST(Lemi025DriverRecordings, StreamFileFirstPacketGlitchDoesNotBlockData) {
  const std::string path = temporary_path("lemi025_driver_test_first_glitch.stream");
  const double t0 = 1709251200.0 + 5 * 86400.0;
  std::vector<double> written = {t0 + 86400.0};
  for (int i = 0; i < 10; ++i) written.push_back(t0 + i);
  write_stream_recording(path, written);
  const std::string ns = "/replay_first_glitch";
  mic::test::FieldInbox recorder(ns);
  DriverProcess driver(ns, {"_source:=stream_file", "_file:=" + path, "_rate:=2.0", "_frame_id:=first_glitch"});
  ASSERT_TRUE(driver.started());
  ASSERT_TRUE(wait_for_stamp(recorder, gps_stamp(t0 + 9, 9), 30.0))
      << recorder.field_count() << " readings; the data after a glitched first packet were not published";
  ros::WallDuration(0.3).sleep();
  const auto fields = recorder.all_fields();
  std::vector<sensor_msgs::MagneticField> from_t4;
  for (const auto& f : fields) {
    EXPECT_LT(f.header.stamp, gps_stamp(t0 + 10, 0)) << "the day-ahead first packet was published";
    if (f.header.stamp >= gps_stamp(t0 + 4, 0)) from_t4.push_back(f);
  }
  ASSERT_EQ(from_t4.size(), 60u);
  for (std::size_t i = 0; i < from_t4.size(); ++i) {
    EXPECT_EQ(from_t4[i].header.stamp, gps_stamp(t0 + 4 + static_cast<double>(i / 10), static_cast<int>(i % 10)))
        << "reading " << i;
  }
  ::unlink(path.c_str());
}

// ---- Impossible parameters ---------------------------------------------------------------------

struct RunResult {
  int exit_code = -1;
  std::string output;
};

/// Runs the driver (the executable next to this test's) with command-line private parameters.
RunResult run_driver(const std::string& name, const std::string& arguments) {
  const std::string command = "timeout 30 " + driver_path() + " __name:=" + name + " " + arguments + " 2>&1";
  RunResult result;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return result;
  char buffer[512];
  while (std::fgets(buffer, sizeof(buffer), pipe)) result.output += buffer;
  const int status = ::pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

TEST(Lemi025DriverParameters, BadParametersExitNonZero) {
  struct Case {
    std::string arguments, parameter;
  };
  const std::vector<Case> cases = {
      {"_source:=usb _device:=/tmp/nowhere", "parameter ~source"},
      {"_baud:=12345 _device:=/tmp/nowhere", "parameter ~baud"},
      {"_source:=serial", "parameter ~device"},  // missing device path
      {"_source:=lemibin _file:=/nonexistent/lemi.bin", "parameter ~file"},
      {"_source:=stream_file", "parameter ~file"},  // missing file
      {"_checksum:=crc16 _device:=/tmp/nowhere", "parameter ~checksum"},
      {"_field:=vertical _device:=/tmp/nowhere", "parameter ~field"},
      {"_rate:=-1 _source:=stream_file _file:=/dev/null", "parameter ~rate"},
      {"_reopen_interval:=0 _device:=/tmp/nowhere", "parameter ~reopen_interval"},
      {"_noise_nT:=-0.1 _device:=/tmp/nowhere", "parameter ~noise_nT"},
  };
  int index = 0;
  for (const Case& c : cases) {
    const std::string name = "bad_lemi025_driver_" + std::to_string(index++);
    const RunResult r = run_driver(name, c.arguments);
    EXPECT_EQ(r.exit_code, 1) << c.arguments << "\n" << r.output;
    EXPECT_NE(r.output.find(c.parameter), std::string::npos) << c.arguments << ": expected '" << c.parameter
                                                            << "' in:\n" << r.output;
    EXPECT_NE(r.output.find("FATAL"), std::string::npos) << r.output;
  }
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
