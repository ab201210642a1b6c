// LEMI-025 packet decoding/encoding against a packet built byte by byte in this file.
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/lemi025_packet.hpp"
#include "test_constants.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

using namespace magnetometer_insitu_calibration;

namespace {

// 2024-03-05 12:34:56 UTC (python: calendar.timegm((2024,3,5,12,34,56))).
using magnetometer_insitu_calibration::test::kT0;

void put_i16(std::vector<std::uint8_t>& b, std::size_t at, int value) {
  const auto u = static_cast<std::uint16_t>(static_cast<std::int16_t>(value));
  b[at] = static_cast<std::uint8_t>(u & 0xFF);
  b[at + 1] = static_cast<std::uint8_t>(u >> 8);
}

void put_packet_f32(std::vector<std::uint8_t>& b, std::size_t at, float value) {
  std::uint32_t bits;
  std::memcpy(&bits, &value, 4);
  for (int i = 0; i < 4; ++i) b[at + i] = static_cast<std::uint8_t>(bits >> (8 * i));
}

float reading_uT(int k, int c) {
  return c == 0 ? 0.5f * k - 1.0f : c == 1 ? -0.25f * k : 0.0625f * k + 10.0f;
}

// The packet of the tests, written field by field from the vendor table.
std::vector<std::uint8_t> hand_packet() {
  std::vector<std::uint8_t> b(153, 0);
  b[0] = 'L'; b[1] = '0'; b[2] = '2'; b[3] = '5';
  b[4] = 7;                                                   // station
  const std::uint8_t time[6] = {0x24, 0x03, 0x05, 0x12, 0x34, 0x56};  // BCD 24-03-05 12:34:56
  std::memcpy(&b[5], time, 6);
  put_i16(b, 11, -1234);  // sensor -12.34 deg C
  put_i16(b, 13, 2550);   // electronics 25.50 deg C
  put_i16(b, 15, 100);    // DAC
  put_i16(b, 17, -200);
  put_i16(b, 19, 300);
  put_i16(b, 21, 8000);   // bias X 20 uT = 20000 nT
  put_i16(b, 23, -1);     // bias Y -2.5 nT
  put_i16(b, 25, 18001);  // bias Z 45002.5 nT
  for (int k = 0; k < 10; ++k)
    for (int c = 0; c < 3; ++c) put_packet_f32(b, 28 + 12 * k + 4 * c, reading_uT(k, c));
  b[148] = 3;    // mode flash + PC
  b[149] = 87;   // flash free %
  b[150] = 123;  // 12.3 V
  b[151] = 'P';
  b[152] = 53;   // sum8 of bytes 0..151 (computed independently with python)
  return b;
}

}  // namespace

TEST(Lemi025Packet, HandBuiltBytesCheckedAgainstPython) {
  // Guards the hand-built packet itself: its middle bytes as python's struct.pack wrote them.
  const std::vector<std::uint8_t> b = hand_packet();
  const std::uint8_t expected[16] = {0x2e, 0xfb, 0xf6, 0x09, 0x64, 0x00, 0x38, 0xff,
                                     0x2c, 0x01, 0x40, 0x1f, 0xff, 0xff, 0x51, 0x46};
  for (int i = 0; i < 16; ++i) EXPECT_EQ(b[11 + i], expected[i]) << "byte " << 11 + i;
}

TEST(Lemi025Packet, DecodesEveryField) {
  const std::vector<std::uint8_t> b = hand_packet();
  const Lemi025Packet p = decode_lemi025_packet(b.data(), ChecksumMode::kSum8);
  EXPECT_EQ(p.model, LemiModel::kLemi025);
  EXPECT_EQ(p.station, 7);
  EXPECT_EQ(p.gps_time_s, kT0);
  EXPECT_DOUBLE_EQ(p.sensor_temperature_C, -12.34);
  EXPECT_DOUBLE_EQ(p.electronics_temperature_C, 25.5);
  EXPECT_EQ(p.dac_counts[0], 100);
  EXPECT_EQ(p.dac_counts[1], -200);
  EXPECT_EQ(p.dac_counts[2], 300);
  EXPECT_DOUBLE_EQ(p.bias_nT[0], 20000.0);
  EXPECT_DOUBLE_EQ(p.bias_nT[1], -2.5);
  EXPECT_DOUBLE_EQ(p.bias_nT[2], 45002.5);
  for (int k = 0; k < 10; ++k)
    for (int c = 0; c < 3; ++c)
      EXPECT_DOUBLE_EQ(p.variation_nT(k, c), 1000.0 * reading_uT(k, c)) << k << "," << c;
  EXPECT_DOUBLE_EQ(p.variation_nT(9, 2), 10562.5);  // 10.5625 uT
  EXPECT_EQ(p.mode, 3);
  EXPECT_EQ(p.flash_free_percent, 87);
  EXPECT_DOUBLE_EQ(p.supply_V, 12.3);
  EXPECT_EQ(p.gps_status, 'P');
  EXPECT_EQ(p.checksum, 53);
}

TEST(Lemi025Packet, SamplesAreShiftedByMinus0p3s) {
  const Lemi025Packet p = decode_lemi025_packet(hand_packet().data());
  EXPECT_NEAR(p.sample_time_s(0), kT0 - 0.3, 1e-6);
  EXPECT_NEAR(p.sample_time_s(3), kT0, 1e-6);
  EXPECT_NEAR(p.sample_time_s(9), kT0 + 0.6, 1e-6);
}

TEST(Lemi025Packet, FullFieldIsBiasPlusVariation) {
  const Lemi025Packet p = decode_lemi025_packet(hand_packet().data());
  const Lemi025Readings full = p.full_field_nT();
  EXPECT_DOUBLE_EQ(full(0, 0), 20000.0 - 1000.0);
  EXPECT_DOUBLE_EQ(full(4, 1), -2.5 - 1000.0);
  EXPECT_DOUBLE_EQ(full(9, 2), 45002.5 + 10562.5);
}

TEST(Lemi025Packet, AcceptsLemi036Tag) {
  std::vector<std::uint8_t> b = hand_packet();
  b[2] = '3';
  b[3] = '6';
  const Lemi025Packet p = decode_lemi025_packet(b.data());
  EXPECT_EQ(p.model, LemiModel::kLemi036);
  EXPECT_EQ(lemi_model_name(p.model), "LEMI-036");
}

TEST(Lemi025Packet, ChecksumModes) {
  std::vector<std::uint8_t> b = hand_packet();
  EXPECT_EQ(lemi025_checksum(b.data(), ChecksumMode::kSum8), 53);
  EXPECT_EQ(lemi025_checksum(b.data(), ChecksumMode::kXor8), 173);  // python, independently
  EXPECT_TRUE(lemi025_checksum_ok(b.data(), ChecksumMode::kSum8));
  EXPECT_FALSE(lemi025_checksum_ok(b.data(), ChecksumMode::kXor8));
  EXPECT_TRUE(lemi025_checksum_ok(b.data(), ChecksumMode::kNone));
  EXPECT_THROW(decode_lemi025_packet(b.data(), ChecksumMode::kXor8), InputError);
  b[152] = 173;
  EXPECT_NO_THROW(decode_lemi025_packet(b.data(), ChecksumMode::kXor8));
  b[60] ^= 0x01;  // one flipped bit in a reading
  EXPECT_FALSE(lemi025_checksum_ok(b.data(), ChecksumMode::kXor8));
  EXPECT_EQ(parse_checksum_mode("sum8"), ChecksumMode::kSum8);
  EXPECT_EQ(parse_checksum_mode("xor8"), ChecksumMode::kXor8);
  EXPECT_EQ(parse_checksum_mode("none"), ChecksumMode::kNone);
  EXPECT_FALSE(parse_checksum_mode("crc16").has_value());
}

TEST(Lemi025Packet, StructureChecks) {
  const std::vector<std::uint8_t> good = hand_packet();
  EXPECT_EQ(check_lemi025_structure(good.data()), Lemi025Problem::kOk);
  auto with = [&](std::size_t at, std::uint8_t value) {
    std::vector<std::uint8_t> b = good;
    b[at] = value;
    return check_lemi025_structure(b.data());
  };
  EXPECT_EQ(with(1, '1'), Lemi025Problem::kBadTag);
  EXPECT_EQ(with(6, 0x1A), Lemi025Problem::kBadTime);   // month nibble A
  EXPECT_EQ(with(6, 0x13), Lemi025Problem::kBadTime);   // month 13
  EXPECT_EQ(with(8, 0x24), Lemi025Problem::kBadTime);   // hour 24
  EXPECT_EQ(with(151, 'X'), Lemi025Problem::kBadStatusBytes);
  EXPECT_EQ(with(148, 0), Lemi025Problem::kBadStatusBytes);
  EXPECT_EQ(with(149, 101), Lemi025Problem::kBadStatusBytes);
  for (char status : {'A', 'P', 'O', 'S'})
    EXPECT_EQ(with(151, static_cast<std::uint8_t>(status)), Lemi025Problem::kOk) << status;
  {
    std::vector<std::uint8_t> b = good;
    b[7] = 0x30;  // 2024-03-30 fine, then February 30th is not
    EXPECT_EQ(check_lemi025_structure(b.data()), Lemi025Problem::kOk);
    b[6] = 0x02;
    EXPECT_EQ(check_lemi025_structure(b.data()), Lemi025Problem::kBadTime);
  }
  {
    std::vector<std::uint8_t> b = good;
    put_packet_f32(b, 28 + 12 * 5 + 4, std::numeric_limits<float>::quiet_NaN());
    EXPECT_EQ(check_lemi025_structure(b.data()), Lemi025Problem::kBadReadings);
    put_packet_f32(b, 28 + 12 * 5 + 4, 100.5f);  // 100500 nT > 100000 nT
    EXPECT_EQ(check_lemi025_structure(b.data()), Lemi025Problem::kBadReadings);
    put_packet_f32(b, 28 + 12 * 5 + 4, -99.5f);
    EXPECT_EQ(check_lemi025_structure(b.data()), Lemi025Problem::kOk);
  }
  Lemi025Plausibility lenient;
  lenient.check_status_bytes = false;
  std::vector<std::uint8_t> b = good;
  b[148] = 0;
  EXPECT_EQ(check_lemi025_structure(b.data(), lenient), Lemi025Problem::kOk);
  try {
    decode_lemi025_packet(b.data());
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "LEMI-025 packet");
    EXPECT_NE(std::string(e.what()).find("mode"), std::string::npos);
  }
}

TEST(Lemi025Packet, EncoderReproducesHandBuiltBytes) {
  const std::vector<std::uint8_t> b = hand_packet();
  const Lemi025Packet p = decode_lemi025_packet(b.data());
  const auto sum = encode_lemi025_packet(p, ChecksumMode::kSum8);
  EXPECT_TRUE(std::equal(sum.begin(), sum.end(), b.begin()));
  const auto xr = encode_lemi025_packet(p, ChecksumMode::kXor8);
  EXPECT_EQ(xr[152], 173);
  const auto none = encode_lemi025_packet(p, ChecksumMode::kNone);
  EXPECT_EQ(none[152], p.checksum);
}

TEST(Lemi025Packet, EncoderFromFields) {
  Lemi025Packet p;
  p.station = 7;
  p.gps_time_s = kT0;
  p.sensor_temperature_C = -12.34;
  p.electronics_temperature_C = 25.5;
  p.dac_counts = {100, -200, 300};
  p.bias_nT = Eigen::Vector3d(20000.0, -2.5, 45002.5);
  for (int k = 0; k < 10; ++k)
    for (int c = 0; c < 3; ++c) p.variation_nT(k, c) = 1000.0 * reading_uT(k, c);
  p.mode = 3;
  p.flash_free_percent = 87;
  p.supply_V = 12.3;
  p.gps_status = 'P';
  const auto bytes = encode_lemi025_packet(p, ChecksumMode::kSum8);
  const std::vector<std::uint8_t> expected = hand_packet();
  for (std::size_t i = 0; i < 153; ++i) EXPECT_EQ(bytes[i], expected[i]) << "byte " << i;
}

TEST(Lemi025Packet, EncoderRefusesValuesThatDoNotFit) {
  Lemi025Packet p;
  p.gps_time_s = 946684799.0;  // 1999-12-31 23:59:59
  EXPECT_THROW(encode_lemi025_packet(p, ChecksumMode::kNone), InputError);
  p.gps_time_s = kT0;
  EXPECT_NO_THROW(encode_lemi025_packet(p, ChecksumMode::kNone));
  p.sensor_temperature_C = 400.0;  // 40000 > int16
  EXPECT_THROW(encode_lemi025_packet(p, ChecksumMode::kNone), InputError);
  p.sensor_temperature_C = 0.0;
  p.bias_nT[0] = 90000.0;  // 36000 counts > int16
  EXPECT_THROW(encode_lemi025_packet(p, ChecksumMode::kNone), InputError);
}

TEST(LemiBcdTime, BcdAndCalendar) {
  EXPECT_EQ(lemi_decode_bcd(0x59), 59);
  EXPECT_EQ(lemi_decode_bcd(0x00), 0);
  EXPECT_FALSE(lemi_decode_bcd(0x5A).has_value());
  EXPECT_FALSE(lemi_decode_bcd(0xA0).has_value());
  EXPECT_EQ(lemi_encode_bcd(47), 0x47);
  EXPECT_THROW(lemi_encode_bcd(100), InputError);
  EXPECT_EQ(lemi_utc_to_unix_s(1970, 1, 1, 0, 0, 0), 0.0);
  EXPECT_EQ(lemi_utc_to_unix_s(2000, 2, 29, 23, 59, 59), 951868799.0);  // python timegm
  EXPECT_EQ(lemi_utc_to_unix_s(2099, 12, 31, 23, 59, 59), 4102444799.0);
  EXPECT_TRUE(std::isnan(lemi_utc_to_unix_s(2100, 2, 29, 0, 0, 0)));  // 2100 is not leap
  EXPECT_TRUE(std::isnan(lemi_utc_to_unix_s(2023, 2, 29, 0, 0, 0)));
  EXPECT_TRUE(std::isnan(lemi_utc_to_unix_s(2024, 4, 31, 0, 0, 0)));
  EXPECT_TRUE(std::isnan(lemi_utc_to_unix_s(2024, 1, 1, 0, 0, 60)));
  const std::array<int, 6> utc = lemi_unix_to_utc(951868799);
  EXPECT_EQ(utc, (std::array<int, 6>{2000, 2, 29, 23, 59, 59}));
  EXPECT_EQ(lemi_unix_to_utc(0), (std::array<int, 6>{1970, 1, 1, 0, 0, 0}));
  const std::uint8_t bcd[6] = {0x24, 0x03, 0x05, 0x12, 0x34, 0x56};
  EXPECT_EQ(lemi_decode_bcd_time(bcd), kT0);
}

// The one plausibility rule (parser, driver, compact flash): finite and |component| <= 100000 nT.
TEST(Lemi025Packet, ReadingPlausibilityRule) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(lemi_reading_plausible(0.0, -99999.9, 100000.0));
  EXPECT_FALSE(lemi_reading_plausible(100000.5, 0.0, 0.0));
  EXPECT_FALSE(lemi_reading_plausible(0.0, -1.0e6, 0.0));
  EXPECT_FALSE(lemi_reading_plausible(0.0, 0.0, nan));
  EXPECT_FALSE(lemi_reading_plausible(-inf, 0.0, 0.0));
  Lemi025Plausibility tight;
  tight.max_abs_variation_nT = 500.0;
  EXPECT_FALSE(lemi_reading_plausible(501.0, 0.0, 0.0, tight));
  EXPECT_TRUE(lemi_reading_plausible(-500.0, 0.0, 0.0, tight));

  Lemi025Readings r = Lemi025Readings::Constant(12.5);
  r(2, 1) = 2.0e5;  // reading 2: Y absurd
  r(6, 0) = nan;    // reading 6: X not finite
  EXPECT_EQ(lemi_mark_implausible_readings(r), 2);
  for (int k = 0; k < 10; ++k)
    for (int c = 0; c < 3; ++c) {
      if (k == 2 || k == 6) {
        EXPECT_TRUE(std::isnan(r(k, c))) << k << "," << c;  // all three components
      } else {
        EXPECT_EQ(r(k, c), 12.5) << k << "," << c;
      }
    }
}

// A packet whose tag, time, status bytes and checksum are good but with implausible readings is
// a packet (check_lemi025_frame), decoded with NaN for those readings only; the strict structure
// check still calls it kBadReadings. Garbage header/time is still not a frame.
TEST(Lemi025Packet, FrameKeepsPacketWithImplausibleReadings) {
  std::vector<std::uint8_t> b = hand_packet();
  put_packet_f32(b, 28 + 12 * 4 + 8, 1.0e30f);                                    // reading 4, Z
  put_packet_f32(b, 28 + 12 * 7 + 0, std::numeric_limits<float>::infinity());     // reading 7, X
  b[152] = lemi025_checksum(b.data(), ChecksumMode::kSum8);
  EXPECT_EQ(check_lemi025_structure(b.data()), Lemi025Problem::kBadReadings);
  for (ChecksumMode mode : {ChecksumMode::kNone, ChecksumMode::kSum8})
    EXPECT_EQ(check_lemi025_frame(b.data(), mode), Lemi025Problem::kOk) << checksum_mode_name(mode);
  // Checksum none and no status-byte check: nothing checks the tail, readings decide.
  Lemi025Plausibility lenient;
  lenient.check_status_bytes = false;
  EXPECT_EQ(check_lemi025_frame(b.data(), ChecksumMode::kNone, lenient), Lemi025Problem::kBadReadings);
  EXPECT_EQ(check_lemi025_frame(b.data(), ChecksumMode::kSum8, lenient), Lemi025Problem::kOk);

  const Lemi025Packet p = decode_lemi025_packet(b.data(), ChecksumMode::kSum8);
  EXPECT_EQ(p.gps_time_s, kT0);
  for (int k = 0; k < 10; ++k) {
    if (k == 4 || k == 7) {
      EXPECT_TRUE(p.variation_nT.row(k).array().isNaN().all()) << "reading " << k;
    } else {
      for (int c = 0; c < 3; ++c) EXPECT_DOUBLE_EQ(p.variation_nT(k, c), 1000.0 * reading_uT(k, c)) << k;
    }
  }
  EXPECT_THROW(decode_lemi025_packet(b.data(), ChecksumMode::kNone, lenient), InputError);

  std::vector<std::uint8_t> garbage_time = b;
  garbage_time[8] = 0x3A;  // hour nibble A: not BCD
  garbage_time[152] = lemi025_checksum(garbage_time.data(), ChecksumMode::kSum8);
  EXPECT_EQ(check_lemi025_frame(garbage_time.data(), ChecksumMode::kSum8), Lemi025Problem::kBadTime);
  std::vector<std::uint8_t> garbage_tag = b;
  garbage_tag[0] = 'X';
  EXPECT_EQ(check_lemi025_frame(garbage_tag.data(), ChecksumMode::kNone), Lemi025Problem::kBadTag);
  std::vector<std::uint8_t> bad_checksum = b;
  bad_checksum[152] ^= 0x01;
  EXPECT_THROW(decode_lemi025_packet(bad_checksum.data(), ChecksumMode::kSum8), InputError);
}
