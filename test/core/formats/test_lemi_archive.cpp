// LemiBin, compact-flash and raw-stream readers on files this test writes byte by byte
// (independently of the library's encoders, which are then checked against the same bytes).
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"
#include "magnetometer_insitu_calibration/instrument/packet_source.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

using namespace magnetometer_insitu_calibration;
using Bytes = std::vector<std::uint8_t>;

namespace {

// 2024-03-05 12:34:50 UTC (python: calendar.timegm((2024,3,5,12,34,50))).
constexpr double kT0 = 1709642090.0;

void put_i16(Bytes& b, std::size_t at, int value) {
  const auto u = static_cast<std::uint16_t>(static_cast<std::int16_t>(value));
  b[at] = static_cast<std::uint8_t>(u & 0xFF);
  b[at + 1] = static_cast<std::uint8_t>(u >> 8);
}

void put_u32(Bytes& b, std::size_t at, std::uint32_t value) {
  for (int i = 0; i < 4; ++i) b[at + i] = static_cast<std::uint8_t>(value >> (8 * i));
}

void put_f32(Bytes& b, std::size_t at, float value) {
  std::uint32_t bits;
  std::memcpy(&bits, &value, 4);
  put_u32(b, at, bits);
}

void append(Bytes& to, const Bytes& from) { to.insert(to.end(), from.begin(), from.end()); }

std::string write_file(const std::string& name, const Bytes& bytes) {
  static const std::string dir = test::make_temp_dir("lemi_archive");
  const std::string path = dir + "/" + name;
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  return path;
}

bool contains(const std::vector<std::string>& lines, const std::string& text) {
  for (const auto& l : lines)
    if (l.find(text) != std::string::npos) return true;
  return false;
}

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
    EXPECT_NEAR(r.time_s[row + k], kT0 + i + shift_s + 0.1 * k, 1e-6) << "row " << row + k;
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
  EXPECT_NEAR(file.records[0].pc_time_s, kT0 + 1.25, 1e-9);
  EXPECT_NEAR(file.records[1].pc_time_s, kT0 + 2.25, 1e-9);
  EXPECT_EQ(file.records[1].packet.gps_time_s, kT0 + 1);
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
    EXPECT_NEAR(r.time_s[20 + k], kT0 + 2 - 0.3 + 0.1 * k, 1e-6);
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
  while (auto p = source.next(0.0)) t.push_back(p->gps_time_s - kT0);
  EXPECT_EQ(t, (std::vector<double>{0, 2}));
  EXPECT_TRUE(source.at_end());
  ASSERT_EQ(source.pc_times_s().size(), 2u);
  EXPECT_NEAR(source.pc_times_s()[1], kT0 + 3.25, 1e-9);
  const PacketSourceStats s = source.stats();
  EXPECT_EQ(s.parser.packets, 2u);
  EXPECT_EQ(s.parser.bytes_skipped, 169u);
  EXPECT_EQ(s.parser.time_jumps, 1u);
  EXPECT_EQ(source.take_warnings().size(), 1u);
}

// ---- Compact flash ---------------------------------------------------------------------------

namespace {

// Block b: caption time 2024-03-05 12:34:(50 + 3b), the vendor table's position example,
// bias (20000, -1000, 40000) nT, reading j = (0.125 j + b, -0.5 - 0.0625 j, 2) uT,
// temperatures 15.00 + 0.01 j and -2.50 deg C.
float flash_reading_uT(int b, int j, int c) {
  return c == 0 ? 0.125f * j + static_cast<float>(b) : c == 1 ? -0.5f - 0.0625f * j : 2.0f;
}

Bytes hand_block(int b) {
  Bytes x(512, 0);
  x[0] = 'L'; x[1] = '0'; x[2] = '2'; x[3] = '5';
  x[4] = 0x47;  // station 47, BCD
  const std::uint8_t time[6] = {0x24, 0x03, 0x05, 0x12, 0x34,
                                static_cast<std::uint8_t>(0x50 + 3 * b)};  // b <= 3
  std::memcpy(&x[5], time, 6);
  const std::uint8_t latitude[5] = {0x49, 0x47, 0x94, 0x45, 0x4e};         // 49 47.9445' N
  const std::uint8_t longitude[6] = {0x00, 0x24, 0x00, 0x54, 0x96, 0x45};  // 0024 00.5496' E
  std::memcpy(&x[11], latitude, 5);
  std::memcpy(&x[16], longitude, 6);
  x[22] = 'A';
  x[23] = 0;
  x[24] = 124;  // 12.4 V
  put_i16(x, 25, 8000);
  put_i16(x, 27, -400);
  put_i16(x, 29, 16000);
  x[31] = 0x5A;
  for (int j = 0; j < 30; ++j) {
    const std::size_t at = 32 + 16 * j;
    for (int c = 0; c < 3; ++c) put_f32(x, at + 4 * c, flash_reading_uT(b, j, c));
    put_i16(x, at + 12, 1500 + j);
    put_i16(x, at + 14, -250);
  }
  return x;
}

void expect_block_rows(const VectorRecord& r, std::size_t row, int b) {
  for (int j = 0; j < 30; ++j) {
    const auto n = static_cast<Eigen::Index>(row + j);
    ASSERT_LT(row + j, r.size());
    EXPECT_NEAR(r.time_s[row + j], kT0 + 3 * b - 0.3 + 0.1 * j, 1e-6) << "row " << row + j;
    EXPECT_DOUBLE_EQ(r.values_nT(n, 0), 20000.0 + 1000.0 * (0.125 * j + b));
    EXPECT_DOUBLE_EQ(r.values_nT(n, 1), -1000.0 + 1000.0 * (-0.5 - 0.0625 * j));
    EXPECT_DOUBLE_EQ(r.values_nT(n, 2), 40000.0 + 2000.0);
  }
}

}  // namespace

TEST(LemiCompactFlash, DecodesCaptionIncludingVendorPositionExample) {
  const Bytes x = hand_block(1);
  const LemiFlashBlock block = decode_lemi_flash_block(x.data());
  EXPECT_EQ(block.model, LemiModel::kLemi025);
  EXPECT_EQ(block.station, 47);
  EXPECT_EQ(block.time_s, kT0 + 3);
  EXPECT_NEAR(block.latitude_deg, 49.0 + 47.9445 / 60.0, 1e-12);   // 49.799075
  EXPECT_NEAR(block.longitude_deg, 24.0 + 0.5496 / 60.0, 1e-12);   // 24.00916
  EXPECT_EQ(block.gps_status, 'A');
  EXPECT_DOUBLE_EQ(block.supply_V, 12.4);
  EXPECT_DOUBLE_EQ(block.bias_nT[0], 20000.0);
  EXPECT_DOUBLE_EQ(block.bias_nT[1], -1000.0);
  EXPECT_DOUBLE_EQ(block.bias_nT[2], 40000.0);
  EXPECT_EQ(block.service, 0x5A);
  EXPECT_DOUBLE_EQ(block.variation_nT(29, 0), 1000.0 * (0.125 * 29 + 1));
  EXPECT_DOUBLE_EQ(block.variation_nT(7, 1), 1000.0 * (-0.5 - 0.0625 * 7));
  EXPECT_DOUBLE_EQ(block.sensor_temperature_C[29], 15.29);
  EXPECT_DOUBLE_EQ(block.electronics_temperature_C[0], -2.5);
}

TEST(LemiCompactFlash, SouthWestAndNoFix) {
  Bytes x = hand_block(0);
  x[15] = 'S';
  x[21] = 'W';
  LemiFlashBlock block = decode_lemi_flash_block(x.data());
  EXPECT_NEAR(block.latitude_deg, -(49.0 + 47.9445 / 60.0), 1e-12);
  EXPECT_NEAR(block.longitude_deg, -(24.0 + 0.5496 / 60.0), 1e-12);
  std::fill(x.begin() + 11, x.begin() + 22, 0xFF);
  block = decode_lemi_flash_block(x.data());
  EXPECT_TRUE(std::isnan(block.latitude_deg));
  EXPECT_TRUE(std::isnan(block.longitude_deg));
}

TEST(LemiCompactFlash, EncoderMatchesHandBuiltBlock) {
  const Bytes x = hand_block(2);
  const auto again = encode_lemi_flash_block(decode_lemi_flash_block(x.data()));
  for (std::size_t i = 0; i < 512; ++i) EXPECT_EQ(again[i], x[i]) << "byte " << i;
}

TEST(LemiCompactFlash, ReadsBlocksSkippingErasedOnes) {
  Bytes card = hand_block(0);
  append(card, hand_block(1));
  append(card, Bytes(512, 0xFF));  // erased
  append(card, hand_block(2));
  append(card, Bytes(2048, 0x00));  // rest of the card
  const std::string path = write_file("card.img", card);
  std::vector<std::string> warnings;
  const VectorRecord r = read_lemi_compact_flash(path, {}, &warnings);
  ASSERT_EQ(r.size(), 90u);
  for (int b = 0; b < 3; ++b) expect_block_rows(r, 30 * b, b);
  EXPECT_EQ(warnings, (std::vector<std::string>{path + ": 5 erased blocks skipped"}));
  EXPECT_EQ(r.header.at("format"), "LEMI compact flash");
  EXPECT_EQ(r.header.at("station_number"), "47");
  EXPECT_NEAR(std::stod(r.header.at("latitude_deg")), 49.799075, 1e-9);
  EXPECT_NEAR(std::stod(r.header.at("longitude_deg")), 24.00916, 1e-9);
}

TEST(LemiCompactFlash, BadBlockReportedAndMisalignmentRecovered) {
  {
    Bytes card = hand_block(0);
    Bytes bad = hand_block(1);
    bad[6] = 0x1F;  // month not BCD
    append(card, bad);
    append(card, hand_block(2));
    const std::string path = write_file("badblock.img", card);
    std::vector<std::string> warnings;
    const VectorRecord r = read_lemi_compact_flash(path, {}, &warnings);
    ASSERT_EQ(r.size(), 60u);
    expect_block_rows(r, 0, 0);
    expect_block_rows(r, 30, 2);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_EQ(warnings[0], path + " byte 512: bad block (caption time is not a valid BCD date), "
                                  "512 bytes skipped");
  }
  {
    Bytes card = hand_block(0);
    append(card, Bytes(7, 0x33));  // 7 stray bytes shift every later block
    append(card, hand_block(1));
    append(card, hand_block(2));
    append(card, Bytes(100, 0x42));  // and a partial block at the end
    const std::string path = write_file("shifted.img", card);
    std::vector<std::string> warnings;
    const std::vector<LemiFlashBlock> blocks = read_lemi_flash_blocks(path, &warnings);
    ASSERT_EQ(blocks.size(), 3u);
    EXPECT_EQ(blocks[1].offset, 519u);
    EXPECT_EQ(blocks[2].offset, 1031u);
    ASSERT_EQ(warnings.size(), 2u);
    EXPECT_EQ(warnings[0], path + " byte 512: bad block (block does not start with L025 / L036), "
                                  "7 bytes skipped");
    EXPECT_EQ(warnings[1], path + " byte 1543: truncated block of 100 bytes at end of file");
  }
}

TEST(LemiCompactFlash, PacketLikeGroupsOfTen) {
  const LemiFlashBlock block = decode_lemi_flash_block(hand_block(1).data());
  const Lemi025Packet p = lemi_flash_block_second(block, 2);
  EXPECT_EQ(p.gps_time_s, kT0 + 3 + 2);
  EXPECT_DOUBLE_EQ(p.variation_nT(0, 0), 1000.0 * (0.125 * 20 + 1));
  EXPECT_DOUBLE_EQ(p.variation_nT(9, 0), 1000.0 * (0.125 * 29 + 1));
  EXPECT_DOUBLE_EQ(p.sensor_temperature_C, 15.20);
  EXPECT_NEAR(p.sample_time_s(0), kT0 + 5 - 0.3, 1e-6);
  EXPECT_THROW(lemi_flash_block_second(block, 3), InputError);

  Bytes card = hand_block(0);
  append(card, hand_block(1));
  CompactFlashPacketSource source(write_file("groups.img", card));
  std::vector<double> t;
  while (auto q = source.next(0.0)) t.push_back(q->gps_time_s - kT0);
  EXPECT_EQ(t, (std::vector<double>{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(source.stats().parser.time_jumps, 0u);
  EXPECT_EQ(source.stats().parser.bytes_skipped, 0u);
}

// The packet parser's plausibility rule (lemi_reading_plausible, one function) on the card:
// a reading that is not finite or has a component beyond +-100000 nT becomes NaN in all three
// components, in the decoded block and in the record; its neighbours and 99000 nT are kept.
TEST(LemiCompactFlash, ImplausibleReadingsBecomeNaN) {
  Bytes bad = hand_block(1);
  auto put_reading = [&](int j, int c, float uT) { put_f32(bad, 32 + 16 * j + 4 * c, uT); };
  put_reading(5, 0, 1000.0f);                                       // 1e6 nT
  put_reading(12, 1, std::numeric_limits<float>::quiet_NaN());      // not finite
  put_reading(20, 2, -150.0f);                                      // -150000 nT
  put_reading(21, 2, 99.0f);                                        // 99000 nT: plausible
  const LemiFlashBlock block = decode_lemi_flash_block(bad.data());
  for (int j = 0; j < 30; ++j) {
    if (j == 5 || j == 12 || j == 20) {
      EXPECT_TRUE(block.variation_nT.row(j).array().isNaN().all()) << "reading " << j;
    } else {
      EXPECT_DOUBLE_EQ(block.variation_nT(j, 0), 1000.0 * (0.125 * j + 1)) << "reading " << j;
    }
  }
  EXPECT_DOUBLE_EQ(block.variation_nT(21, 2), 99000.0);
  EXPECT_DOUBLE_EQ(block.variation_nT(21, 1), 1000.0 * (-0.5 - 0.0625 * 21));

  Bytes card = hand_block(0);
  append(card, bad);
  append(card, hand_block(2));
  const VectorRecord r = read_lemi_compact_flash(write_file("implausible.img", card));
  ASSERT_EQ(r.size(), 90u);
  expect_block_rows(r, 0, 0);
  expect_block_rows(r, 60, 2);
  for (int j = 0; j < 30; ++j) {
    const Eigen::Index n = 30 + j;
    EXPECT_NEAR(r.time_s[30 + j], kT0 + 3 - 0.3 + 0.1 * j, 1e-6);
    if (j == 5 || j == 12 || j == 20) {
      EXPECT_TRUE(r.values_nT.row(n).array().isNaN().all()) << "reading " << j;
    } else if (j != 21) {
      EXPECT_DOUBLE_EQ(r.values_nT(n, 0), 20000.0 + 1000.0 * (0.125 * j + 1)) << "reading " << j;
      EXPECT_DOUBLE_EQ(r.values_nT(n, 2), 42000.0) << "reading " << j;
    }
  }
  EXPECT_DOUBLE_EQ(r.values_nT(51, 2), 40000.0 + 99000.0);  // bias + variation, nT
}

TEST(LemiCompactFlash, NoBlockAtAll) {
  EXPECT_THROW(read_lemi_compact_flash(write_file("empty.img", Bytes(4096, 0xFF))), InputError);
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
