// LemiBin files: header line + 169-byte records (layout in lemi_archive.hpp).
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"

#include "lemi_bytes.hpp"
#include "lemi_file_bytes.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>

namespace magnetometer_insitu_calibration {

namespace {

constexpr std::size_t kPcTime = kLemi025PacketSize;          // six int16
constexpr std::size_t kPcMicroseconds = kPcTime + 6 * 2;    // uint32
constexpr std::size_t kMaxHeaderLine = 4096;

// The problem of the record at p (kOk if it is a good one). Where the previous record ended
// (aligned) the packet's frame rule decides, as on a live stream: an implausible reading does not
// reject an intact record, it is set to NaN. While resynchronising at an arbitrary offset every
// reading must be plausible too (strict), so that a misaligned position is not taken for a record.
Lemi025Problem check_record(const std::uint8_t* p, const LemiReadOptions& options, bool strict) {
  Lemi025Problem problem = strict ? check_lemi025_structure(p, options.plausibility)
                                  : check_lemi025_frame(p, options.checksum, options.plausibility);
  if (problem == Lemi025Problem::kOk && !lemi025_checksum_ok(p, options.checksum))
    problem = Lemi025Problem::kBadChecksum;
  return problem;
}

double decode_pc_time(const std::uint8_t* p) {
  using lemi_detail::read_i16;
  const double microseconds = lemi_detail::read_u32(p + 12);
  if (microseconds >= 1e6) return std::numeric_limits<double>::quiet_NaN();
  return lemi_utc_to_unix_s(2000 + read_i16(p), read_i16(p + 2), read_i16(p + 4), read_i16(p + 6),
                            read_i16(p + 8), read_i16(p + 10)) +
         microseconds * 1e-6;
}

std::string where(const std::string& path, std::size_t offset) {
  return path + " byte " + std::to_string(offset);
}

}  // namespace

LemiBinFile read_lemi_bin_file(const std::string& path, const LemiReadOptions& options,
                               std::vector<std::string>* warnings) {
  const std::vector<std::uint8_t> bytes = lemi_detail::read_file_bytes(path);
  const std::size_t size = bytes.size();
  LemiBinFile file;
  std::size_t pos = 0;
  static const std::string kMagic = "LemiBin";
  if (size >= kMagic.size() && std::equal(kMagic.begin(), kMagic.end(), bytes.begin())) {
    std::size_t end = 0;
    while (end < size && end < kMaxHeaderLine && bytes[end] != '\n') ++end;
    if (end == size || end == kMaxHeaderLine)
      throw InputError(path, "LemiBin header line has no end of line");
    file.header_line.assign(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(end));
    if (!file.header_line.empty() && file.header_line.back() == '\r') file.header_line.pop_back();
    std::istringstream words(file.header_line);
    std::vector<std::string> tokens;
    for (std::string w; words >> w;) tokens.push_back(w);
    if (tokens.size() > 1) file.sensor_id = tokens[1];
    if (tokens.size() > 2) {
      char* rest = nullptr;
      const long declared = std::strtol(tokens.back().c_str(), &rest, 10);
      if (rest != nullptr && *rest == '\0' && declared != static_cast<long>(kLemiBinRecordSize))
        throw InputError(path, "header declares " + tokens.back() + "-byte records, only " +
                                   std::to_string(kLemiBinRecordSize) + " are supported");
    }
    pos = end + 1;
  }

  auto warn = [&](const std::string& message) {
    if (warnings != nullptr) warnings->push_back(message);
  };
  while (pos < size) {
    if (size - pos < kLemiBinRecordSize) {
      warn(where(path, pos) + ": truncated record of " + std::to_string(size - pos) +
           " bytes at end of file");
      break;
    }
    const Lemi025Problem problem = check_record(bytes.data() + pos, options, false);
    if (problem == Lemi025Problem::kOk) {
      LemiBinRecord record;
      record.packet = decode_lemi025_packet_unchecked(bytes.data() + pos);
      const int implausible = lemi_mark_implausible_readings(record.packet.variation_nT, options.plausibility);
      if (implausible > 0) {
        warn(where(path, pos) + ": " + std::to_string(implausible) +
             " implausible reading(s) (not finite or beyond the range) set to NaN, the record kept");
      }
      record.pc_time_s = decode_pc_time(bytes.data() + pos + kPcTime);
      record.offset = pos;
      file.records.push_back(std::move(record));
      pos += kLemiBinRecordSize;
      continue;
    }
    // Resynchronise on the next good record, at any alignment.
    std::size_t next = pos + 1;
    while (next + kLemiBinRecordSize <= size &&
           !(lemi_detail::is_lemi_tag(bytes.data() + next) &&
             check_record(bytes.data() + next, options, true) == Lemi025Problem::kOk))
      ++next;
    if (next + kLemiBinRecordSize > size) {
      warn(where(path, pos) + ": bad record (" + lemi025_problem_text(problem) +
           "), no valid record after it (" + std::to_string(size - pos) + " bytes skipped)");
      break;
    }
    warn(where(path, pos) + ": bad record (" + lemi025_problem_text(problem) + "), " +
         std::to_string(next - pos) + " bytes skipped");
    pos = next;
  }
  if (file.records.empty()) throw InputError(path, "no valid LEMI-025 record (not a LemiBin file?)");
  return file;
}

VectorRecord read_lemi_bin(const std::string& path, const LemiReadOptions& options,
                           std::vector<std::string>* warnings) {
  const LemiBinFile file = read_lemi_bin_file(path, options, warnings);
  std::vector<Lemi025Packet> packets;
  packets.reserve(file.records.size());
  for (const LemiBinRecord& r : file.records) packets.push_back(r.packet);
  std::vector<std::string> record_warnings;
  VectorRecord record = lemi025_packets_to_record(packets, options, &record_warnings);
  if (warnings != nullptr)
    for (const std::string& w : record_warnings) warnings->push_back(path + ": " + w);
  record.source = path;
  record.header["format"] = "LemiBin";
  if (!file.sensor_id.empty()) record.header["sensor_id"] = file.sensor_id;
  return record;
}

void write_lemi_bin(const std::string& path, const std::vector<LemiBinRecord>& records,
                    const std::string& sensor_id, ChecksumMode mode) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw InputError(path, "cannot create");
  out << "LemiBin " << sensor_id
      << " [x,y,z,t1,t2] [X,Y,Z,T_sensor,T_elec] [nT,nT,nT,deg_C,deg_C]"
         " [0.001,0.001,0.001,100,100] <4cb6B8hb30f3BcB6hL "
      << kLemiBinRecordSize << "\n";
  for (const LemiBinRecord& r : records) {
    std::array<std::uint8_t, kLemiBinRecordSize> b{};
    const auto packet = encode_lemi025_packet(r.packet, mode);
    std::copy(packet.begin(), packet.end(), b.begin());
    double whole = std::floor(r.pc_time_s);
    long microseconds = std::lround((r.pc_time_s - whole) * 1e6);
    if (microseconds >= 1000000) {
      whole += 1.0;
      microseconds -= 1000000;
    }
    const std::array<int, 6> utc = lemi_unix_to_utc(static_cast<std::int64_t>(whole));
    lemi_detail::write_i16(b.data() + kPcTime, static_cast<std::int16_t>(utc[0] - 2000));
    for (int i = 1; i < 6; ++i)
      lemi_detail::write_i16(b.data() + kPcTime + 2 * i, static_cast<std::int16_t>(utc[i]));
    lemi_detail::write_u32(b.data() + kPcMicroseconds, static_cast<std::uint32_t>(microseconds));
    out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
  }
  if (!out) throw InputError(path, "write error");
}

}  // namespace magnetometer_insitu_calibration
