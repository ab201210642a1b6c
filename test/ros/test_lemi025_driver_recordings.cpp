// rostest (with test_lemi025_driver.test, in the test_lemi025_driver binary): lemi025_driver
// started by the test itself on recordings written here.
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
// Each replay starts when this test's subscription is connected (~wait_for_subscribers 1), so no
// reading is lost to a slow start-up and every one is checked.
#include "magnetometer_insitu_calibration/formats/lemi025_packet.hpp"
#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"
#include "driver_process.hpp"
#include "driver_test_support.hpp"
#include "lemi025_test_packets.hpp"

#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/MagneticField.h>

#include <unistd.h>

#include <cmath>
#include <fstream>
#include <limits>
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
using mic::test::DriverProcess;
using mic::test::temporary_path;

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
  DriverProcess driver(ns, {"_source:=compact_flash", "_file:=" + path, "_rate:=10.0", "_frame_id:=flash",
                            "_wait_for_subscribers:=1"});
  ASSERT_TRUE(driver.started());
  // The last block's readings come last: wait for its final reading.
  const ros::Time last_stamp = gps_stamp(t0 + 29.0, 9);
  ASSERT_TRUE(wait_for(
      [&] {
        const auto f = recorder.all_fields();
        return !f.empty() && f.back().header.stamp >= last_stamp;
      }))
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
  EXPECT_EQ(checked, 300u) << "every reading (the replay waits for the subscriber)";
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
  DriverProcess driver(ns, {"_source:=lemibin", "_file:=" + path, "_rate:=10.0", "_wait_for_subscribers:=1"});
  ASSERT_TRUE(driver.started());
  ASSERT_TRUE(wait_for(
      [&] {
        const auto f = recorder.all_fields();
        // The last reading of the last packet, stamped with its PC time t0 + 3619.75. The
        // packet's ten readings (0.1 s apart from t0 + 3618.85) arrive one by one; waiting for a
        // stamp past t0 + 3619 stopped at the third and counted 93 of the 100 passive readings
        // (seen on a fresh clone).
        return !f.empty() && f.back().header.stamp.toSec() > t0 + 3600.0 + 19.75 - 1e-3;
      }))
      << recorder.field_count() << " readings";
  const auto fields = recorder.all_fields();
  std::size_t passive_readings = 0;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    if (i > 0) {
      EXPECT_GT(fields[i].header.stamp, fields[i - 1].header.stamp);
    }
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
bool wait_for_stamp(mic::test::FieldInbox& inbox, const ros::Time& stamp) {
  return wait_for([&] {
    const auto f = inbox.all_fields();
    return !f.empty() && f.back().header.stamp >= stamp;
  });
}

/// Waits until the replay node `node` ("<ns>/replay") reports the end of its recording on
/// /diagnostics: everything it will publish has been published.
void wait_end_of_recording(mic::test::DriverDiagnostics& diagnostics) {
  EXPECT_TRUE(wait_for([&] { return diagnostics.value("link", "end of recording") == "True"; }))
      << "no end of recording in the diagnostics";
}

// A raw stream recording (~source stream_file) through the driver's GPS-time screening: a packet
// whose GPS second is a day ahead (in the slot of t0 + 2) is dropped, the seconds around it are
// published; the last packet jumps 46 s ahead and has no later packet to confirm it: it is held,
// then published at the end of the recording. The replay waits for this test's subscription
// (~wait_for_subscribers), so every reading is checked against the truth.
TEST(Lemi025DriverRecordings, StreamFileGpsGlitchDroppedAndLastHeldPacketReleased) {
  const std::string path = temporary_path("lemi025_driver_test_glitch.stream");
  const double t0 = 1709251200.0 + 3 * 86400.0;
  write_stream_recording(path, {t0 - 4, t0 - 3, t0 - 2, t0 - 1, t0, t0 + 1, t0 + 86400.0, t0 + 3, t0 + 4, t0 + 50});
  const std::string ns = "/replay_glitch";
  mic::test::FieldInbox recorder(ns);
  mic::test::DriverDiagnostics diagnostics(ns.substr(1) + "/replay");
  DriverProcess driver(ns, {"_source:=stream_file", "_file:=" + path, "_rate:=2.0", "_frame_id:=glitch",
                            "_wait_for_subscribers:=1"});
  ASSERT_TRUE(driver.started());
  ASSERT_TRUE(wait_for_stamp(recorder, gps_stamp(t0 + 50, 9)))
      << recorder.field_count() << " readings; the held last packet was not released at the end";
  wait_end_of_recording(diagnostics);
  const auto fields = recorder.all_fields();
  std::vector<sensor_msgs::MagneticField> published;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    if (i > 0) {
      EXPECT_GT(fields[i].header.stamp, fields[i - 1].header.stamp) << "reading " << i;
    }
    EXPECT_LT(fields[i].header.stamp, gps_stamp(t0 + 51, 0)) << "the day-ahead glitch was published";
    published.push_back(fields[i]);
  }
  const std::vector<double> truth = {t0 - 4, t0 - 3, t0 - 2, t0 - 1, t0, t0 + 1, t0 + 3, t0 + 4, t0 + 50};
  ASSERT_EQ(published.size(), 10 * truth.size());
  for (std::size_t i = 0; i < published.size(); ++i) {
    const double s = truth[i / 10];
    const int k = static_cast<int>(i % 10);
    EXPECT_EQ(published[i].header.stamp, gps_stamp(s, k)) << "reading " << i;
    EXPECT_NEAR(published[i].magnetic_field.y, (kBias_nT(1) + make_packet(s).variation_nT(k, 1)) * kNanotesla,
                1e-4 * kNanotesla)
        << "reading " << i;
  }
  ::unlink(path.c_str());
}

// The FIRST packet of a recording carries a day-ahead GPS second (a receiver glitch at start-up):
// it has no reference to be checked against, so it is held like any jump and dropped when the
// packets after it run on from each other. Before, it became the reference and every later
// packet was "backwards": nothing was published until real time caught up. Every reading from
// t0 on must arrive (the replay waits for this test's subscription).
TEST(Lemi025DriverRecordings, StreamFileFirstPacketGlitchDoesNotBlockData) {
  const std::string path = temporary_path("lemi025_driver_test_first_glitch.stream");
  const double t0 = 1709251200.0 + 5 * 86400.0;
  std::vector<double> written = {t0 + 86400.0};
  for (int i = 0; i < 10; ++i) written.push_back(t0 + i);
  write_stream_recording(path, written);
  const std::string ns = "/replay_first_glitch";
  mic::test::FieldInbox recorder(ns);
  mic::test::DriverDiagnostics diagnostics(ns.substr(1) + "/replay");
  DriverProcess driver(ns, {"_source:=stream_file", "_file:=" + path, "_rate:=2.0", "_frame_id:=first_glitch",
                            "_wait_for_subscribers:=1"});
  ASSERT_TRUE(driver.started());
  ASSERT_TRUE(wait_for_stamp(recorder, gps_stamp(t0 + 9, 9)))
      << recorder.field_count() << " readings; the data after a glitched first packet were not published";
  wait_end_of_recording(diagnostics);
  const auto fields = recorder.all_fields();
  for (const auto& f : fields) {
    EXPECT_LT(f.header.stamp, gps_stamp(t0 + 10, 0)) << "the day-ahead first packet was published";
  }
  ASSERT_EQ(fields.size(), 100u);
  for (std::size_t i = 0; i < fields.size(); ++i) {
    EXPECT_EQ(fields[i].header.stamp, gps_stamp(t0 + static_cast<double>(i / 10), static_cast<int>(i % 10)))
        << "reading " << i;
  }
  ::unlink(path.c_str());
}

}  // namespace
