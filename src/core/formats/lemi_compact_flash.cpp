// LEMI-025 compact-flash card: 512-byte blocks (layout and choices in lemi_archive.hpp).
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"

#include "lemi_bytes.hpp"
#include "lemi_file_bytes.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace magnetometer_insitu_calibration {

namespace {

constexpr const char* kBlockSource = "LEMI compact-flash block";  // InputError's source

// Caption byte offsets.
constexpr std::size_t kCaptionStation = 4;
constexpr std::size_t kCaptionTime = 5;
constexpr std::size_t kCaptionLatitude = 11;   // 5 bytes
constexpr std::size_t kCaptionLongitude = 16;  // 6 bytes
constexpr std::size_t kCaptionGpsStatus = 22;
constexpr std::size_t kCaptionReserved = 23;
constexpr std::size_t kCaptionSupply = 24;
constexpr std::size_t kCaptionBias = 25;
constexpr std::size_t kCaptionService = 31;
constexpr std::size_t kBlockReadingSize = 16;

std::optional<int> bcd4(const std::uint8_t* p) {  // two BCD bytes = four digits
  const auto hi = lemi_decode_bcd(p[0]);
  const auto lo = lemi_decode_bcd(p[1]);
  if (!hi || !lo) return std::nullopt;
  return *hi * 100 + *lo;
}

// Degrees from BCD degrees, BCD minutes, 4 BCD digits of ten-thousandths of a minute and a
// hemisphere char; `degree_bytes` is 1 (latitude) or 2 (longitude).
double decode_position(const std::uint8_t* p, int degree_bytes, char positive, char negative) {
  const std::optional<int> degrees = degree_bytes == 1 ? lemi_decode_bcd(p[0]) : bcd4(p);
  const std::optional<int> minutes = lemi_decode_bcd(p[degree_bytes]);
  const std::optional<int> fraction = bcd4(p + degree_bytes + 1);
  const char hemisphere = static_cast<char>(p[degree_bytes + 3]);
  if (!degrees || !minutes || !fraction || *minutes > 59 ||
      (hemisphere != positive && hemisphere != negative))
    return std::numeric_limits<double>::quiet_NaN();
  const double value = *degrees + (*minutes + *fraction / 10000.0) / 60.0;
  return hemisphere == negative ? -value : value;
}

void encode_position(double deg, std::uint8_t* p, int degree_bytes, char positive, char negative) {
  if (!std::isfinite(deg)) {
    std::fill(p, p + degree_bytes + 4, 0xFF);  // not BCD: "no position"
    return;
  }
  const char hemisphere = deg < 0 ? negative : positive;
  long ten_thousandths = std::lround(std::abs(deg) * 60.0 * 10000.0);  // of a minute
  const long degrees = ten_thousandths / 600000;
  ten_thousandths -= degrees * 600000;
  const long minutes = ten_thousandths / 10000;
  const long fraction = ten_thousandths % 10000;
  if (degrees > (degree_bytes == 1 ? 90 : 180))
    throw InputError(kBlockSource, "position out of range");
  if (degree_bytes == 1) {
    p[0] = lemi_encode_bcd(static_cast<int>(degrees));
  } else {
    p[0] = lemi_encode_bcd(static_cast<int>(degrees / 100));
    p[1] = lemi_encode_bcd(static_cast<int>(degrees % 100));
  }
  p[degree_bytes] = lemi_encode_bcd(static_cast<int>(minutes));
  p[degree_bytes + 1] = lemi_encode_bcd(static_cast<int>(fraction / 100));
  p[degree_bytes + 2] = lemi_encode_bcd(static_cast<int>(fraction % 100));
  p[degree_bytes + 3] = static_cast<std::uint8_t>(hemisphere);
}

// Empty string if the caption at p is valid, else the problem.
std::string caption_problem(const std::uint8_t* p) {
  if (!lemi_detail::is_lemi_tag(p)) return "block does not start with L025 / L036";
  if (std::isnan(lemi_decode_bcd_time(p + kCaptionTime))) return "caption time is not a valid BCD date";
  return "";
}

bool is_erased(const std::uint8_t* p) {
  return std::all_of(p, p + kLemiFlashBlockSize, [](std::uint8_t b) { return b == 0x00; }) ||
         std::all_of(p, p + kLemiFlashBlockSize, [](std::uint8_t b) { return b == 0xFF; });
}

}  // namespace

LemiFlashBlock decode_lemi_flash_block(const std::uint8_t* b) {
  using namespace lemi_detail;
  const std::string problem = caption_problem(b);
  if (!problem.empty()) throw InputError(kBlockSource, problem);
  LemiFlashBlock block;
  block.model = b[2] == '3' ? LemiModel::kLemi036 : LemiModel::kLemi025;
  const std::optional<int> station = lemi_decode_bcd(b[kCaptionStation]);
  block.station = station ? *station : b[kCaptionStation];
  block.time_s = lemi_decode_bcd_time(b + kCaptionTime);
  block.latitude_deg = decode_position(b + kCaptionLatitude, 1, 'N', 'S');
  block.longitude_deg = decode_position(b + kCaptionLongitude, 2, 'E', 'W');
  block.gps_status = static_cast<char>(b[kCaptionGpsStatus]);
  block.reserved = b[kCaptionReserved];
  block.supply_V = b[kCaptionSupply] / 10.0;
  for (int c = 0; c < 3; ++c) block.bias_nT[c] = read_i16(b + kCaptionBias + 2 * c) * kLemi025BiasStep_nT;
  block.service = b[kCaptionService];
  for (int j = 0; j < kLemiFlashReadingsPerBlock; ++j) {
    const std::uint8_t* r = b + kLemiFlashCaptionSize + kBlockReadingSize * j;
    for (int c = 0; c < 3; ++c) block.variation_nT(j, c) = 1000.0 * read_f32(r + 4 * c);  // uT
    block.sensor_temperature_C[j] = read_i16(r + 12) / 100.0;
    block.electronics_temperature_C[j] = read_i16(r + 14) / 100.0;
  }
  // The packet parser's plausibility rule (one function): a reading that is not finite or out
  // of range becomes NaN in all three components, never a number.
  lemi_mark_implausible_readings(block.variation_nT);
  return block;
}

std::array<std::uint8_t, kLemiFlashBlockSize> encode_lemi_flash_block(const LemiFlashBlock& block) {
  using namespace lemi_detail;
  std::array<std::uint8_t, kLemiFlashBlockSize> b{};
  b[0] = 'L';
  b[1] = '0';
  b[2] = block.model == LemiModel::kLemi036 ? '3' : '2';
  b[3] = block.model == LemiModel::kLemi036 ? '6' : '5';
  b[kCaptionStation] = lemi_encode_bcd(block.station);
  if (!std::isfinite(block.time_s)) throw InputError(kBlockSource, "time not finite");
  const std::array<int, 6> utc =
      lemi_unix_to_utc(static_cast<std::int64_t>(std::llround(block.time_s)));
  if (utc[0] < 2000 || utc[0] > 2099)
    throw InputError(kBlockSource, "year outside 2000-2099");
  b[kCaptionTime] = lemi_encode_bcd(utc[0] - 2000);
  for (int i = 1; i < 6; ++i) b[kCaptionTime + i] = lemi_encode_bcd(utc[i]);
  encode_position(block.latitude_deg, b.data() + kCaptionLatitude, 1, 'N', 'S');
  encode_position(block.longitude_deg, b.data() + kCaptionLongitude, 2, 'E', 'W');
  b[kCaptionGpsStatus] = static_cast<std::uint8_t>(block.gps_status);
  b[kCaptionReserved] = block.reserved;
  const double supply = std::round(block.supply_V * 10.0);
  if (!(supply >= 0 && supply <= 255)) throw InputError(kBlockSource, "supply voltage");
  b[kCaptionSupply] = static_cast<std::uint8_t>(supply);
  for (int c = 0; c < 3; ++c)
    write_i16(b.data() + kCaptionBias + 2 * c, checked_int16(block.bias_nT[c] / kLemi025BiasStep_nT, kBlockSource, "bias"));
  b[kCaptionService] = block.service;
  for (int j = 0; j < kLemiFlashReadingsPerBlock; ++j) {
    std::uint8_t* r = b.data() + kLemiFlashCaptionSize + kBlockReadingSize * j;
    for (int c = 0; c < 3; ++c) write_f32(r + 4 * c, static_cast<float>(block.variation_nT(j, c) / 1000.0));
    write_i16(r + 12, checked_int16(block.sensor_temperature_C[j] * 100.0, kBlockSource, "sensor temperature"));
    write_i16(r + 14, checked_int16(block.electronics_temperature_C[j] * 100.0, kBlockSource, "electronics temperature"));
  }
  return b;
}

std::vector<LemiFlashBlock> read_lemi_flash_blocks(const std::string& path,
                                                   std::vector<std::string>* warnings) {
  const std::vector<std::uint8_t> bytes = lemi_detail::read_file_bytes(path);
  const std::size_t size = bytes.size();
  auto warn = [&](const std::string& message) {
    if (warnings != nullptr) warnings->push_back(message);
  };
  auto where = [&](std::size_t offset) { return path + " byte " + std::to_string(offset); };
  std::vector<LemiFlashBlock> blocks;
  std::size_t erased = 0;
  std::size_t pos = 0;
  while (pos + kLemiFlashBlockSize <= size) {
    const std::uint8_t* p = bytes.data() + pos;
    if (is_erased(p)) {
      ++erased;
      pos += kLemiFlashBlockSize;
      continue;
    }
    const std::string problem = caption_problem(p);
    if (problem.empty()) {
      blocks.push_back(decode_lemi_flash_block(p));
      blocks.back().offset = pos;
      pos += kLemiFlashBlockSize;
      continue;
    }
    std::size_t next = pos + 1;
    while (next + kLemiFlashBlockSize <= size && !caption_problem(bytes.data() + next).empty())
      ++next;
    if (next + kLemiFlashBlockSize > size) {
      warn(where(pos) + ": bad block (" + problem + "), no valid block after it (" +
           std::to_string(size - pos) + " bytes skipped)");
      pos = size;
      break;
    }
    warn(where(pos) + ": bad block (" + problem + "), " + std::to_string(next - pos) +
         " bytes skipped");
    pos = next;
  }
  if (pos < size &&
      !std::all_of(bytes.begin() + static_cast<std::ptrdiff_t>(pos), bytes.end(),
                   [](std::uint8_t b) { return b == 0x00 || b == 0xFF; }))
    warn(where(pos) + ": truncated block of " + std::to_string(size - pos) + " bytes at end of file");
  if (erased > 0) warn(path + ": " + std::to_string(erased) + " erased blocks skipped");
  if (blocks.empty()) throw InputError(path, "no valid LEMI-025 compact-flash block");
  return blocks;
}

Lemi025Packet lemi_flash_block_second(const LemiFlashBlock& block, int second) {
  if (second < 0 || second > 2) throw InputError("lemi_flash_block_second", "second must be 0..2");
  Lemi025Packet p;
  p.model = block.model;
  p.station = static_cast<std::uint8_t>(std::clamp(block.station, 0, 255));
  p.gps_time_s = block.time_s + second;
  const int first = kLemi025ReadingsPerPacket * second;
  p.sensor_temperature_C = block.sensor_temperature_C[first];
  p.electronics_temperature_C = block.electronics_temperature_C[first];
  p.bias_nT = block.bias_nT;
  p.variation_nT = block.variation_nT.middleRows<kLemi025ReadingsPerPacket>(first);
  p.mode = 1;
  p.flash_free_percent = 0;
  p.supply_V = block.supply_V;
  p.gps_status = block.gps_status;
  return p;
}

VectorRecord read_lemi_compact_flash(const std::string& path, const LemiReadOptions& options,
                                     std::vector<std::string>* warnings) {
  const std::vector<LemiFlashBlock> blocks = read_lemi_flash_blocks(path, warnings);
  std::vector<Lemi025Packet> packets;
  packets.reserve(3 * blocks.size());
  for (const LemiFlashBlock& block : blocks)
    for (int s = 0; s < 3; ++s) packets.push_back(lemi_flash_block_second(block, s));
  std::vector<std::string> record_warnings;
  VectorRecord record = lemi025_packets_to_record(packets, options, &record_warnings);
  if (warnings != nullptr)
    for (const std::string& w : record_warnings) warnings->push_back(path + ": " + w);
  record.source = path;
  record.header["format"] = "LEMI compact flash";
  for (const LemiFlashBlock& block : blocks) {
    if (std::isfinite(block.latitude_deg) && std::isfinite(block.longitude_deg)) {
      std::ostringstream lat, lon;
      lat.precision(10);
      lon.precision(10);
      lat << block.latitude_deg;
      lon << block.longitude_deg;
      record.header["latitude_deg"] = lat.str();
      record.header["longitude_deg"] = lon.str();
      break;
    }
  }
  return record;
}

}  // namespace magnetometer_insitu_calibration
