// LEMI-025 packet: decode, encode, checksums, BCD and calendar helpers (layout in the header).
#include "magnetometer_insitu_calibration/formats/lemi025_packet.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "lemi_bytes.hpp"

#include <cmath>
#include <cstring>
#include <limits>

namespace magnetometer_insitu_calibration {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Byte offsets in the packet.
constexpr std::size_t kStation = 4;
constexpr std::size_t kTime = 5;
constexpr std::size_t kSensorTemp = 11;
constexpr std::size_t kElectronicsTemp = 13;
constexpr std::size_t kDac = 15;
constexpr std::size_t kBias = 21;
constexpr std::size_t kReserved = 27;
constexpr std::size_t kReadings = 28;
constexpr std::size_t kMode = 148;
constexpr std::size_t kFlashFree = 149;
constexpr std::size_t kSupply = 150;
constexpr std::size_t kGpsStatus = 151;
constexpr std::size_t kChecksum = 152;

bool is_leap(int year) { return (year % 4 == 0 && year % 100 != 0) || year % 400 == 0; }

int days_in_month(int year, int month) {
  static const int kDays[12] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  return month == 2 && is_leap(year) ? 29 : kDays[month - 1];
}

// Days since 1970-01-01 of a proleptic Gregorian date (H. Hinnant's days_from_civil).
std::int64_t days_from_civil(std::int64_t y, unsigned m, unsigned d) {
  y -= m <= 2;
  const std::int64_t era = (y >= 0 ? y : y - 399) / 400;
  const unsigned yoe = static_cast<unsigned>(y - era * 400);
  const unsigned doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + static_cast<std::int64_t>(doe) - 719468;
}

std::int16_t checked_int16(double value, const char* what) {
  return lemi_detail::checked_int16(value, "LEMI-025 packet", what);
}

std::uint8_t checked_uint8(double value, const char* what) {
  const double rounded = std::round(value);
  if (!(rounded >= 0.0 && rounded <= 255.0))
    throw InputError("LEMI-025 packet", std::string(what) + " does not fit its uint8 field");
  return static_cast<std::uint8_t>(rounded);
}

}  // namespace

std::string lemi_model_name(LemiModel model) {
  return model == LemiModel::kLemi036 ? "LEMI-036" : "LEMI-025";
}

std::string checksum_mode_name(ChecksumMode mode) {
  switch (mode) {
    case ChecksumMode::kSum8: return "sum8";
    case ChecksumMode::kXor8: return "xor8";
    case ChecksumMode::kNone: break;
  }
  return "none";
}

std::optional<ChecksumMode> parse_checksum_mode(const std::string& text) {
  if (text == "none") return ChecksumMode::kNone;
  if (text == "sum8") return ChecksumMode::kSum8;
  if (text == "xor8") return ChecksumMode::kXor8;
  return std::nullopt;
}

double Lemi025Packet::sample_time_s(int k) const {
  // (k - 3) / 10 rather than -0.3 + 0.1 k: one rounding instead of three.
  return gps_time_s + static_cast<double>(k - 3) / 10.0;
}

Lemi025Readings Lemi025Packet::full_field_nT() const {
  Lemi025Readings full = variation_nT;
  full.rowwise() += bias_nT.transpose();
  return full;
}

std::string lemi025_problem_text(Lemi025Problem problem) {
  switch (problem) {
    case Lemi025Problem::kOk: return "ok";
    case Lemi025Problem::kBadTag: return "tag is neither L025 nor L036";
    case Lemi025Problem::kBadTime: return "GPS time is not a valid BCD date and time";
    case Lemi025Problem::kBadReadings: return "a reading is not finite or out of range";
    case Lemi025Problem::kBadStatusBytes: return "mode, flash-free or GPS-status byte is invalid";
    case Lemi025Problem::kBadChecksum: return "checksum mismatch";
  }
  return "unknown problem";
}

bool lemi_reading_plausible(double x_nT, double y_nT, double z_nT,
                            const Lemi025Plausibility& limits) {
  // !(a <= b) rather than a > b: NaN is implausible too.
  for (const double v : {x_nT, y_nT, z_nT})
    if (!std::isfinite(v) || !(std::abs(v) <= limits.max_abs_variation_nT)) return false;
  return true;
}

namespace {

// Tag, BCD date/time, status bytes (the frame without the readings).
Lemi025Problem check_header_time_status(const std::uint8_t* bytes,
                                        const Lemi025Plausibility& limits) {
  if (!lemi_detail::is_lemi_tag(bytes)) return Lemi025Problem::kBadTag;
  if (std::isnan(lemi_decode_bcd_time(bytes + kTime))) return Lemi025Problem::kBadTime;
  if (limits.check_status_bytes) {
    const std::uint8_t mode = bytes[kMode];
    const char gps = static_cast<char>(bytes[kGpsStatus]);
    if (mode < 1 || mode > 3 || bytes[kFlashFree] > 100 ||
        !(gps == 'A' || gps == 'P' || gps == 'O' || gps == 'S'))
      return Lemi025Problem::kBadStatusBytes;
  }
  return Lemi025Problem::kOk;
}

bool all_readings_plausible(const std::uint8_t* bytes, const Lemi025Plausibility& limits) {
  for (int k = 0; k < kLemi025ReadingsPerPacket; ++k) {
    const std::uint8_t* r = bytes + kReadings + 12 * k;
    if (!lemi_reading_plausible(1000.0 * lemi_detail::read_f32(r), 1000.0 * lemi_detail::read_f32(r + 4),
                                1000.0 * lemi_detail::read_f32(r + 8), limits))  // uT -> nT
      return false;
  }
  return true;
}

}  // namespace

Lemi025Problem check_lemi025_structure(const std::uint8_t* bytes,
                                       const Lemi025Plausibility& limits) {
  if (!lemi_detail::is_lemi_tag(bytes)) return Lemi025Problem::kBadTag;
  if (std::isnan(lemi_decode_bcd_time(bytes + kTime))) return Lemi025Problem::kBadTime;
  if (!all_readings_plausible(bytes, limits)) return Lemi025Problem::kBadReadings;
  return check_header_time_status(bytes, limits);
}

Lemi025Problem check_lemi025_frame(const std::uint8_t* bytes, ChecksumMode checksum,
                                   const Lemi025Plausibility& limits) {
  const Lemi025Problem problem = check_header_time_status(bytes, limits);
  if (problem != Lemi025Problem::kOk) return problem;
  if (checksum == ChecksumMode::kNone && !limits.check_status_bytes &&
      !all_readings_plausible(bytes, limits))
    return Lemi025Problem::kBadReadings;
  return Lemi025Problem::kOk;
}

std::uint8_t lemi025_checksum(const std::uint8_t* bytes, ChecksumMode mode) {
  std::uint8_t sum = 0;
  switch (mode) {
    case ChecksumMode::kSum8:
      for (std::size_t i = 0; i < kChecksum; ++i) sum = static_cast<std::uint8_t>(sum + bytes[i]);
      break;
    case ChecksumMode::kXor8:
      for (std::size_t i = 0; i < kChecksum; ++i) sum = static_cast<std::uint8_t>(sum ^ bytes[i]);
      break;
    case ChecksumMode::kNone: break;
  }
  return sum;
}

bool lemi025_checksum_ok(const std::uint8_t* bytes, ChecksumMode mode) {
  return mode == ChecksumMode::kNone || bytes[kChecksum] == lemi025_checksum(bytes, mode);
}

Lemi025Packet decode_lemi025_packet_unchecked(const std::uint8_t* bytes) {
  using namespace lemi_detail;
  Lemi025Packet p;
  p.model = bytes[1] == '0' && bytes[2] == '3' && bytes[3] == '6' ? LemiModel::kLemi036
                                                                  : LemiModel::kLemi025;
  p.station = bytes[kStation];
  p.gps_time_s = lemi_decode_bcd_time(bytes + kTime);
  p.sensor_temperature_C = read_i16(bytes + kSensorTemp) / 100.0;
  p.electronics_temperature_C = read_i16(bytes + kElectronicsTemp) / 100.0;
  for (int c = 0; c < 3; ++c) {
    p.dac_counts[c] = read_i16(bytes + kDac + 2 * c);
    p.bias_nT[c] = read_i16(bytes + kBias + 2 * c) * kLemi025BiasStep_nT;  // x400 uT = 2.5 nT
  }
  p.reserved = bytes[kReserved];
  for (int k = 0; k < kLemi025ReadingsPerPacket; ++k)
    for (int c = 0; c < 3; ++c)
      p.variation_nT(k, c) = 1000.0 * read_f32(bytes + kReadings + 12 * k + 4 * c);  // uT -> nT
  p.mode = bytes[kMode];
  p.flash_free_percent = bytes[kFlashFree];
  p.supply_V = bytes[kSupply] / 10.0;
  p.gps_status = static_cast<char>(bytes[kGpsStatus]);
  p.checksum = bytes[kChecksum];
  return p;
}

Lemi025Packet decode_lemi025_packet(const std::uint8_t* bytes, ChecksumMode mode,
                                    const Lemi025Plausibility& limits) {
  Lemi025Problem problem = check_lemi025_frame(bytes, mode, limits);
  if (problem == Lemi025Problem::kOk && !lemi025_checksum_ok(bytes, mode))
    problem = Lemi025Problem::kBadChecksum;
  if (problem != Lemi025Problem::kOk)
    throw InputError("LEMI-025 packet", lemi025_problem_text(problem));
  Lemi025Packet packet = decode_lemi025_packet_unchecked(bytes);
  lemi_mark_implausible_readings(packet.variation_nT, limits);
  return packet;
}

std::array<std::uint8_t, kLemi025PacketSize> encode_lemi025_packet(const Lemi025Packet& p,
                                                                   ChecksumMode mode) {
  using namespace lemi_detail;
  std::array<std::uint8_t, kLemi025PacketSize> b{};
  b[0] = 'L';
  b[1] = '0';
  b[2] = p.model == LemiModel::kLemi036 ? '3' : '2';
  b[3] = p.model == LemiModel::kLemi036 ? '6' : '5';
  b[kStation] = p.station;
  if (!std::isfinite(p.gps_time_s))
    throw InputError("LEMI-025 packet", "GPS time is not finite");
  const std::array<int, 6> utc =
      lemi_unix_to_utc(static_cast<std::int64_t>(std::llround(p.gps_time_s)));
  if (utc[0] < 2000 || utc[0] > 2099)
    throw InputError("LEMI-025 packet", "year " + std::to_string(utc[0]) + " outside 2000-2099");
  b[kTime] = lemi_encode_bcd(utc[0] - 2000);
  for (int i = 1; i < 6; ++i) b[kTime + i] = lemi_encode_bcd(utc[i]);
  write_i16(b.data() + kSensorTemp, checked_int16(p.sensor_temperature_C * 100.0, "sensor temperature"));
  write_i16(b.data() + kElectronicsTemp,
            checked_int16(p.electronics_temperature_C * 100.0, "electronics temperature"));
  for (int c = 0; c < 3; ++c) {
    write_i16(b.data() + kDac + 2 * c, p.dac_counts[c]);
    write_i16(b.data() + kBias + 2 * c, checked_int16(p.bias_nT[c] / kLemi025BiasStep_nT, "bias"));
  }
  b[kReserved] = p.reserved;
  for (int k = 0; k < kLemi025ReadingsPerPacket; ++k)
    for (int c = 0; c < 3; ++c)
      write_f32(b.data() + kReadings + 12 * k + 4 * c,
                static_cast<float>(p.variation_nT(k, c) / 1000.0));  // nT -> uT
  b[kMode] = p.mode;
  b[kFlashFree] = p.flash_free_percent;
  b[kSupply] = checked_uint8(p.supply_V * 10.0, "supply voltage");
  b[kGpsStatus] = static_cast<std::uint8_t>(p.gps_status);
  b[kChecksum] = mode == ChecksumMode::kNone ? p.checksum : lemi025_checksum(b.data(), mode);
  return b;
}

// ---- BCD and calendar ------------------------------------------------------------------------

std::optional<int> lemi_decode_bcd(std::uint8_t byte) {
  const int hi = byte >> 4;
  const int lo = byte & 0x0F;
  if (hi > 9 || lo > 9) return std::nullopt;
  return hi * 10 + lo;
}

std::uint8_t lemi_encode_bcd(int value) {
  if (value < 0 || value > 99) throw InputError("BCD", std::to_string(value) + " outside 0-99");
  return static_cast<std::uint8_t>(((value / 10) << 4) | (value % 10));
}

double lemi_utc_to_unix_s(int year, int month, int day, int hour, int minute, double second) {
  if (month < 1 || month > 12 || day < 1 || day > days_in_month(year, month) || hour < 0 ||
      hour > 23 || minute < 0 || minute > 59 || !(second >= 0.0 && second < 60.0))
    return kNaN;
  const std::int64_t days = days_from_civil(year, static_cast<unsigned>(month),
                                            static_cast<unsigned>(day));
  return static_cast<double>(days * 86400 + hour * 3600 + minute * 60) + second;
}

std::array<int, 6> lemi_unix_to_utc(std::int64_t unix_s) {
  std::int64_t days = unix_s >= 0 ? unix_s / 86400 : -((-unix_s + 86399) / 86400);
  std::int64_t secs = unix_s - days * 86400;
  // H. Hinnant's civil_from_days.
  days += 719468;
  const std::int64_t era = (days >= 0 ? days : days - 146096) / 146097;
  const unsigned doe = static_cast<unsigned>(days - era * 146097);
  const unsigned yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
  const std::int64_t y = static_cast<std::int64_t>(yoe) + era * 400;
  const unsigned doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
  const unsigned mp = (5 * doy + 2) / 153;
  const unsigned d = doy - (153 * mp + 2) / 5 + 1;
  const unsigned m = mp < 10 ? mp + 3 : mp - 9;
  return {static_cast<int>(y + (m <= 2)), static_cast<int>(m), static_cast<int>(d),
          static_cast<int>(secs / 3600), static_cast<int>(secs % 3600 / 60),
          static_cast<int>(secs % 60)};
}

double lemi_decode_bcd_time(const std::uint8_t* b) {
  int f[6];
  for (int i = 0; i < 6; ++i) {
    const std::optional<int> v = lemi_decode_bcd(b[i]);
    if (!v) return kNaN;
    f[i] = *v;
  }
  return lemi_utc_to_unix_s(2000 + f[0], f[1], f[2], f[3], f[4], f[5]);
}

}  // namespace magnetometer_insitu_calibration
