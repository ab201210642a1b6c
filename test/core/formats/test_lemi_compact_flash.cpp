// LEMI compact-flash reader on blocks this test writes byte by byte (independently of the
// library's encoder, which is then checked against the same bytes).
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
    EXPECT_NEAR(r.time_s[row + j], kArchiveT0 + 3 * b - 0.3 + 0.1 * j, 1e-6) << "row " << row + j;
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
  EXPECT_EQ(block.time_s, kArchiveT0 + 3);
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
  // Temperatures beside the field: each second's ten readings carry its first reading's
  // (sensor 15.00 + 0.01 j deg C for reading j of a block, electronics -2.50 deg C).
  ASSERT_EQ(r.auxiliary.size(), 2u);
  ASSERT_EQ(r.auxiliary[0].values.size(), r.size());
  for (std::size_t row = 0; row < r.size(); ++row) {
    const std::size_t j = row % 30 / 10 * 10;  // first reading of the row's second in its block
    EXPECT_NEAR(r.auxiliary[0].values[row], 15.0 + 0.01 * static_cast<double>(j), 1e-12) << row;
    EXPECT_DOUBLE_EQ(r.auxiliary[1].values[row], -2.5) << row;
  }
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
  EXPECT_EQ(p.gps_time_s, kArchiveT0 + 3 + 2);
  EXPECT_DOUBLE_EQ(p.variation_nT(0, 0), 1000.0 * (0.125 * 20 + 1));
  EXPECT_DOUBLE_EQ(p.variation_nT(9, 0), 1000.0 * (0.125 * 29 + 1));
  EXPECT_DOUBLE_EQ(p.sensor_temperature_C, 15.20);
  EXPECT_NEAR(p.sample_time_s(0), kArchiveT0 + 5 - 0.3, 1e-6);
  EXPECT_THROW(lemi_flash_block_second(block, 3), InputError);

  Bytes card = hand_block(0);
  append(card, hand_block(1));
  CompactFlashPacketSource source(write_file("groups.img", card));
  std::vector<double> t;
  while (auto q = source.next(0.0)) t.push_back(q->gps_time_s - kArchiveT0);
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
    EXPECT_NEAR(r.time_s[30 + j], kArchiveT0 + 3 - 0.3 + 0.1 * j, 1e-6);
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
