// LemiBin and raw-stream readers on files this test writes byte by byte (independently of the
// library's encoders, which are then checked against the same bytes). Compact flash:
// test_lemi_compact_flash.cpp.
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"
#include "magnetometer_insitu_calibration/instrument/packet_source.hpp"

#include "test_support.hpp"
#include "lemi_test_bytes.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

using namespace magnetometer_insitu_calibration;
using namespace lemi_test;

namespace {

// ---- LemiBin ----------------------------------------------------------------------------------

// Serial packet i: 2024-03-05 12:34:(50+i), bias (20000, 0, -40000) nT,
// reading k = (0.25 k + i, -0.5 k, 1.5) uT, GPS 'A'.
float packet_reading_uT(int i, int k, int c) {
  return c == 0 ? 0.25f * k + static_cast<float>(i) : c == 1 ? -0.5f * k : 1.5f;
}

Bytes hand_packet(int i) {
  Bytes b(153, 0);
  b[0] = 'L'; b[1] = '0'; b[2] = '2'; b[3] = '5';
  b[4] = 9;
  const std::uint8_t time[6] = {0x24, 0x03, 0x05, 0x12, 0x34,
                                static_cast<std::uint8_t>(0x50 + i)};  // i < 10
  std::memcpy(&b[5], time, 6);
  put_i16(b, 11, 2150);    // 21.5 deg C
  put_i16(b, 13, -325);    // -3.25 deg C
  put_i16(b, 21, 8000);    // 20000 nT
  put_i16(b, 23, 0);
  put_i16(b, 25, -16000);  // -40000 nT
  for (int k = 0; k < 10; ++k)
    for (int c = 0; c < 3; ++c) put_f32(b, 28 + 12 * k + 4 * c, packet_reading_uT(i, k, c));
  b[148] = 2;
  b[149] = 99;
  b[150] = 120;
  b[151] = 'A';
  std::uint8_t sum = 0;
  for (int j = 0; j < 152; ++j) sum = static_cast<std::uint8_t>(sum + b[j]);
  b[152] = sum;
  return b;
}

// LemiBin record i: packet i + PC time 2024-03-05 12:34:(51+i).250000.
Bytes hand_record(int i) {
  Bytes b = hand_packet(i);
  b.resize(169, 0);
  const int pc[6] = {24, 3, 5, 12, 34, 51 + i};
  for (int f = 0; f < 6; ++f) put_i16(b, 153 + 2 * f, pc[f]);
  put_u32(b, 165, 250000);
  return b;
}

const std::string kHeader =
    "LemiBin TEST025 [x,y,z,t1,t2] [X,Y,Z,T_sensor,T_elec] [nT,nT,nT,deg_C,deg_C] "
    "[0.001,0.001,0.001,100,100] <4cb6B8hb30f3BcB6hL 169\n";

Bytes lemi_bin(const std::vector<Bytes>& records, bool header = true) {
  Bytes b;
  if (header) b.assign(kHeader.begin(), kHeader.end());
  for (const Bytes& r : records) append(b, r);
  return b;
}

void expect_packet_rows(const VectorRecord& r, std::size_t row, int i, bool full_field,
                        double shift_s = -0.3) {
  for (int k = 0; k < 10; ++k) {
    const auto n = static_cast<Eigen::Index>(row + k);
    ASSERT_LT(row + k, r.size());
    EXPECT_NEAR(r.time_s[row + k], kArchiveT0 + i + shift_s + 0.1 * k, 1e-6) << "row " << row + k;
    EXPECT_DOUBLE_EQ(r.values_nT(n, 0), (full_field ? 20000.0 : 0.0) + 1000.0 * (0.25 * k + i));
    EXPECT_DOUBLE_EQ(r.values_nT(n, 1), -500.0 * k);
    EXPECT_DOUBLE_EQ(r.values_nT(n, 2), (full_field ? -40000.0 : 0.0) + 1500.0);
  }
}

}  // namespace

TEST(LemiBin, ReadsFullFieldAt10HzWithShift) {
  const std::string path =
      write_file("five.bin", lemi_bin({hand_record(0), hand_record(1), hand_record(2),
                                       hand_record(3), hand_record(4)}));
  std::vector<std::string> warnings;
  const VectorRecord r = read_lemi_bin(path, {}, &warnings);
  EXPECT_TRUE(warnings.empty());
  ASSERT_EQ(r.size(), 50u);
  ASSERT_EQ(r.values_nT.rows(), 50);
  for (int i = 0; i < 5; ++i) expect_packet_rows(r, 10 * i, i, true);
  EXPECT_EQ(r.source, path);
  EXPECT_EQ(r.header.at("format"), "LemiBin");
  EXPECT_EQ(r.header.at("sensor_id"), "TEST025");
  EXPECT_EQ(r.header.at("instrument"), "LEMI-025");
  EXPECT_EQ(r.header.at("station_number"), "9");
  EXPECT_EQ(r.header.at("bias_changes"), "0");
  // The packets' temperatures (21.50 and -3.25 deg C in the bytes) beside every reading.
  ASSERT_EQ(r.auxiliary.size(), 2u);
  EXPECT_EQ(r.auxiliary[0].name, "sensor_temperature");
  EXPECT_EQ(r.auxiliary[0].unit, "degC");
  EXPECT_EQ(r.auxiliary[1].name, "electronics_temperature");
  for (const AuxiliaryChannel& a : r.auxiliary) ASSERT_EQ(a.values.size(), r.size()) << a.name;
  for (std::size_t i = 0; i < r.size(); ++i) {
    EXPECT_DOUBLE_EQ(r.auxiliary[0].values[i], 21.5) << i;
    EXPECT_DOUBLE_EQ(r.auxiliary[1].values[i], -3.25) << i;
  }
}

TEST(LemiBin, VariationModeAndOtherShift) {
  const std::string path = write_file("two.bin", lemi_bin({hand_record(0), hand_record(1)}));
  LemiReadOptions options;
  options.field = LemiFieldMode::kVariation;
  options.time_shift_s = 0.0;
  const VectorRecord r = read_lemi_bin(path, options);
  ASSERT_EQ(r.size(), 20u);
  expect_packet_rows(r, 0, 0, false, 0.0);
  expect_packet_rows(r, 10, 1, false, 0.0);
}

TEST(LemiBin, RecordsKeepPcTimeAndOffsets) {
  const std::string path = write_file("pc.bin", lemi_bin({hand_record(0), hand_record(1)}));
  const LemiBinFile file = read_lemi_bin_file(path);
  EXPECT_EQ(file.header_line + "\n", kHeader);
  EXPECT_EQ(file.sensor_id, "TEST025");
  ASSERT_EQ(file.records.size(), 2u);
  EXPECT_EQ(file.records[0].offset, kHeader.size());
  EXPECT_EQ(file.records[1].offset, kHeader.size() + 169);
  EXPECT_NEAR(file.records[0].pc_time_s, kArchiveT0 + 1.25, 1e-9);
  EXPECT_NEAR(file.records[1].pc_time_s, kArchiveT0 + 2.25, 1e-9);
  EXPECT_EQ(file.records[1].packet.gps_time_s, kArchiveT0 + 1);
  EXPECT_DOUBLE_EQ(file.records[1].packet.sensor_temperature_C, 21.5);
  EXPECT_DOUBLE_EQ(file.records[1].packet.electronics_temperature_C, -3.25);
  EXPECT_DOUBLE_EQ(file.records[1].packet.supply_V, 12.0);
}

TEST(LemiBin, FileWithoutHeaderLine) {
  const std::string path = write_file("nohead.bin", lemi_bin({hand_record(0), hand_record(1)}, false));
  const LemiBinFile file = read_lemi_bin_file(path);
  EXPECT_EQ(file.header_line, "");
  ASSERT_EQ(file.records.size(), 2u);
  EXPECT_EQ(file.records[0].offset, 0u);
}

TEST(LemiBin, BadRecordIsReportedWithOffsetAndTheRestIsKept) {
  Bytes broken = hand_record(2);
  broken[1] = 'X';  // tag destroyed
  const std::string path = write_file(
      "bad.bin", lemi_bin({hand_record(0), hand_record(1), broken, hand_record(3), hand_record(4)}));
  std::vector<std::string> warnings;
  const VectorRecord r = read_lemi_bin(path, {}, &warnings);
  ASSERT_EQ(r.size(), 40u);
  expect_packet_rows(r, 0, 0, true);
  expect_packet_rows(r, 10, 1, true);
  expect_packet_rows(r, 20, 3, true);
  expect_packet_rows(r, 30, 4, true);
  ASSERT_EQ(warnings.size(), 1u);
  const std::size_t offset = kHeader.size() + 2 * 169;
  EXPECT_EQ(warnings[0], path + " byte " + std::to_string(offset) +
                             ": bad record (tag is neither L025 nor L036), 169 bytes skipped");
}

// An aligned record with intact tag, time and status bytes but implausible readings (a failing
// ADC): kept, those readings NaN in x, y and z, the others as recorded, one warning naming the
// record's byte offset. Resynchronising after a broken record still needs every reading plausible.
TEST(LemiBin, ImplausibleReadingsBecomeNaNAndTheRecordIsKept) {
  Bytes odd = hand_record(2);
  put_f32(odd, 28 + 12 * 3 + 4 * 1, 1000.0f);                                  // reading 3: y 1e6 nT
  put_f32(odd, 28 + 12 * 7 + 4 * 2, std::numeric_limits<float>::infinity());   // reading 7: z
  const std::string path = write_file(
      "implausible.bin", lemi_bin({hand_record(0), hand_record(1), odd, hand_record(3)}));
  std::vector<std::string> warnings;
  const VectorRecord r = read_lemi_bin(path, {}, &warnings);
  ASSERT_EQ(r.size(), 40u);
  expect_packet_rows(r, 0, 0, true);
  expect_packet_rows(r, 10, 1, true);
  expect_packet_rows(r, 30, 3, true);
  for (int k = 0; k < 10; ++k) {
    const Eigen::Index n = 20 + k;
    EXPECT_NEAR(r.time_s[20 + k], kArchiveT0 + 2 - 0.3 + 0.1 * k, 1e-6);
    if (k == 3 || k == 7) {
      EXPECT_TRUE(r.values_nT.row(n).array().isNaN().all()) << "reading " << k;
    } else {
      EXPECT_DOUBLE_EQ(r.values_nT(n, 0), 20000.0 + 1000.0 * (0.25 * k + 2)) << "reading " << k;
      EXPECT_DOUBLE_EQ(r.values_nT(n, 1), -500.0 * k) << "reading " << k;
    }
  }
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], path + " byte " + std::to_string(kHeader.size() + 2 * 169) +
                             ": 2 implausible reading(s) (not finite or beyond the range) set to NaN, the record kept");

  // After a destroyed tag the reader searches at every offset: a record with an implausible
  // reading is not taken as the resynchronisation point, the next clean one is (the odd record's
  // good readings are lost there: the price of not resynchronising on a misaligned position).
  Bytes broken = hand_record(1);
  broken[0] = 'X';
  const std::string resync_path = write_file(
      "resync.bin", lemi_bin({hand_record(0), broken, odd, hand_record(3)}));
  warnings.clear();
  const VectorRecord after = read_lemi_bin(resync_path, {}, &warnings);
  ASSERT_EQ(after.size(), 20u);
  expect_packet_rows(after, 0, 0, true);
  expect_packet_rows(after, 10, 3, true);
  ASSERT_EQ(warnings.size(), 1u) << warnings[0];
  EXPECT_NE(warnings[0].find(std::to_string(2 * 169) + " bytes skipped"), std::string::npos) << warnings[0];
}

TEST(LemiBin, InterruptedWriteMidRecordResynchronises) {
  Bytes cut = hand_record(2);
  cut.resize(100);  // acquisition stopped after 100 bytes of record 2
  const std::string path = write_file(
      "cut.bin", lemi_bin({hand_record(0), hand_record(1), cut, hand_record(3), hand_record(4)}));
  std::vector<std::string> warnings;
  const VectorRecord r = read_lemi_bin(path, {}, &warnings);
  ASSERT_EQ(r.size(), 40u);
  expect_packet_rows(r, 20, 3, true);
  expect_packet_rows(r, 30, 4, true);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("byte " + std::to_string(kHeader.size() + 2 * 169) + ": bad record"),
            std::string::npos)
      << warnings[0];
  EXPECT_NE(warnings[0].find("100 bytes skipped"), std::string::npos) << warnings[0];
}

TEST(LemiBin, TruncatedLastRecordIsReported) {
  Bytes last = hand_record(2);
  last.resize(50);
  const std::string path = write_file("tail.bin", lemi_bin({hand_record(0), hand_record(1), last}));
  std::vector<std::string> warnings;
  const VectorRecord r = read_lemi_bin(path, {}, &warnings);
  EXPECT_EQ(r.size(), 20u);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], path + " byte " + std::to_string(kHeader.size() + 2 * 169) +
                             ": truncated record of 50 bytes at end of file");
}

TEST(LemiBin, RepeatedRecordKeepsTimesStrictlyIncreasing) {
  const std::string path =
      write_file("dup.bin", lemi_bin({hand_record(0), hand_record(1), hand_record(1), hand_record(2)}));
  std::vector<std::string> warnings;
  const VectorRecord r = read_lemi_bin(path, {}, &warnings);
  ASSERT_EQ(r.size(), 30u);
  for (std::size_t i = 1; i < r.size(); ++i) EXPECT_GT(r.time_s[i], r.time_s[i - 1]);
  expect_packet_rows(r, 20, 2, true);
  EXPECT_TRUE(contains(warnings, "10 of its readings dropped")) << warnings.size();
}

TEST(LemiBin, ChecksumOption) {
  const std::string path = write_file("sum.bin", lemi_bin({hand_record(0), hand_record(1)}));
  LemiReadOptions options;
  options.checksum = ChecksumMode::kSum8;  // hand_packet writes sum8
  EXPECT_EQ(read_lemi_bin(path, options).size(), 20u);
  options.checksum = ChecksumMode::kXor8;
  EXPECT_THROW(read_lemi_bin(path, options), InputError);
}

TEST(LemiBin, Errors) {
  try {
    read_lemi_bin("/nonexistent/lemi.bin");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "/nonexistent/lemi.bin");
  }
  const std::string garbage = write_file("garbage.bin", Bytes(1000, 0x42));
  EXPECT_THROW(read_lemi_bin(garbage), InputError);
  std::string other = kHeader;
  other.replace(other.find(" 169\n"), 5, " 153\n");
  Bytes b(other.begin(), other.end());
  append(b, hand_record(0));
  EXPECT_THROW(read_lemi_bin(write_file("size.bin", b)), InputError);
}

TEST(LemiBin, WriterMatchesHandBuiltBytes) {
  const Bytes expected = lemi_bin({hand_record(0), hand_record(1)});
  const std::string path = write_file("hand.bin", expected);
  const LemiBinFile file = read_lemi_bin_file(path);
  const std::string again = path + ".rewritten";
  write_lemi_bin(again, file.records, "TEST025", ChecksumMode::kSum8);
  std::ifstream in(again, std::ios::binary);
  const Bytes written((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(written, expected);
}

TEST(LemiBin, PacketSource) {
  Bytes broken = hand_record(1);
  broken[0] = 0;
  const std::string path = write_file("src.bin", lemi_bin({hand_record(0), broken, hand_record(2)}));
  LemiBinPacketSource source(path);
  std::vector<double> t;
  while (auto p = source.next(0.0)) t.push_back(p->gps_time_s - kArchiveT0);
  EXPECT_EQ(t, (std::vector<double>{0, 2}));
  EXPECT_TRUE(source.at_end());
  ASSERT_EQ(source.pc_times_s().size(), 2u);
  EXPECT_NEAR(source.pc_times_s()[1], kArchiveT0 + 3.25, 1e-9);
  const PacketSourceStats s = source.stats();
  EXPECT_EQ(s.parser.packets, 2u);
  EXPECT_EQ(s.parser.bytes_skipped, 169u);
  EXPECT_EQ(s.parser.time_jumps, 1u);
  EXPECT_EQ(source.take_warnings().size(), 1u);
}

// ---- Raw stream capture ----------------------------------------------------------------------

TEST(LemiStreamCapture, ReadsPacketsWithFileOffsetsInWarnings) {
  Bytes capture = {0x01, 0x02, 0x03, 'L', '0'};  // connection opened mid-packet
  append(capture, hand_packet(0));
  append(capture, hand_packet(1));
  Bytes cut = hand_packet(2);
  cut.resize(120);
  append(capture, cut);
  append(capture, hand_packet(3));
  const std::string path = write_file("capture.raw", capture);
  std::vector<std::string> warnings;
  const VectorRecord r = read_lemi025_stream(path, {}, &warnings);
  ASSERT_EQ(r.size(), 30u);
  expect_packet_rows(r, 0, 0, true);
  expect_packet_rows(r, 10, 1, true);
  expect_packet_rows(r, 20, 3, true);
  EXPECT_EQ(r.header.at("bytes_skipped"), "125");
  EXPECT_EQ(r.header.at("time_jumps"), "1");
  EXPECT_TRUE(contains(warnings, path + " byte 0: skipped 5 bytes")) << warnings.size();
  EXPECT_TRUE(contains(warnings, path + " byte " + std::to_string(5 + 2 * 153) + ": skipped 120"));
}
