// Format detection and dispatch; see record_file.hpp.
#include "magnetometer_insitu_calibration/formats/record_file.hpp"

#include "magnetometer_insitu_calibration/formats/cdf_records.hpp"
#include "magnetometer_insitu_calibration/formats/csv_record.hpp"
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <fstream>
#include <optional>

namespace magnetometer_insitu_calibration {

namespace {

std::string upper(std::string text) {
  for (char& c : text) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return text;
}

// CDF and the LEMI binary formats from the first bytes of the file; nullopt for text (or unreadable).
std::optional<RecordFormat> detect_binary_format(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;  // TextLineReader reports it
  std::vector<std::uint8_t> bytes(1 << 16);
  in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  bytes.resize(static_cast<std::size_t>(in.gcount()));
  const std::size_t size = bytes.size();
  if (size >= 8) {
    auto word = [&](std::size_t p) {
      return (std::uint32_t{bytes[p]} << 24) | (std::uint32_t{bytes[p + 1]} << 16) | (std::uint32_t{bytes[p + 2]} << 8) |
             bytes[p + 3];
    };
    const std::uint32_t first = word(0), second = word(4);
    if (first == 0xCDF30001u || first == 0xCDF26002u || (first == 0x0000FFFFu && second == 0x0000FFFFu)) {
      return RecordFormat::kCdf;
    }
  }
  if (size >= 2 && bytes[0] == 0x1f && bytes[1] == 0x8b) return std::nullopt;  // gzip: text
  // A rosbag is read by topic, not as a record file: say so rather than fail on its first "line".
  if (size >= 9 && std::equal(bytes.begin(), bytes.begin() + 9, "#ROSBAG V")) {
    throw InputError(path, "is a rosbag: its records are read by topic (calibrate_records --bag FILE "
                           "--reference-topic T --test-topic T; export_corrected --bag FILE --test-topic T)");
  }
  if (size >= 7 && std::equal(bytes.begin(), bytes.begin() + 7, "LemiBin")) return RecordFormat::kLemiBin;
  auto packet_at = [&](std::size_t p) {
    return p + kLemi025PacketSize <= size && check_lemi025_structure(bytes.data() + p) == Lemi025Problem::kOk;
  };
  std::optional<std::size_t> first_packet;
  for (std::size_t p = 0; p + kLemi025PacketSize <= size; ++p) {
    if (bytes[p] != 'L' || !packet_at(p)) continue;
    if (!first_packet) first_packet = p;
    if (packet_at(p + kLemiBinRecordSize)) return RecordFormat::kLemiBin;
    if (packet_at(p + kLemi025PacketSize)) return RecordFormat::kLemi025Stream;
  }
  for (std::size_t p = 0; p + kLemiFlashBlockSize <= size; p += kLemiFlashBlockSize) {
    const std::uint8_t* block = bytes.data() + p;
    const bool erased = std::all_of(block, block + kLemiFlashBlockSize, [](std::uint8_t b) { return b == 0x00; }) ||
                        std::all_of(block, block + kLemiFlashBlockSize, [](std::uint8_t b) { return b == 0xFF; });
    if (erased) continue;
    try {
      decode_lemi_flash_block(block);
      return RecordFormat::kLemiCompactFlash;
    } catch (const InputError&) {
    }
    break;
  }
  if (first_packet) return RecordFormat::kLemi025Stream;
  return std::nullopt;
}

}  // namespace

const char* record_format_name(RecordFormat format) {
  switch (format) {
    case RecordFormat::kIaga2002:
      return "IAGA-2002";
    case RecordFormat::kCsv:
      return "CSV";
    case RecordFormat::kLemiBin:
      return "LemiBin";
    case RecordFormat::kLemiCompactFlash:
      return "LEMI compact flash";
    case RecordFormat::kLemi025Stream:
      return "LEMI-025 byte stream";
    case RecordFormat::kCdf:
      return "CDF";
  }
  return "unknown";
}

RecordFormat detect_record_format(const std::string& path) {
  if (const std::optional<RecordFormat> binary = detect_binary_format(path)) return *binary;
  TextLineReader reader(path);
  std::string line;
  while (reader.next(line)) {
    const std::string content = upper(trim_blanks(line));
    if (content.empty()) continue;
    if (content.compare(0, 6, "FORMAT") == 0 && content.find("IAGA-2002") != std::string::npos) {
      return RecordFormat::kIaga2002;
    }
    return RecordFormat::kCsv;
  }
  return RecordFormat::kCsv;
}

VectorRecord read_record(const std::string& path) { return read_record(path, LemiReadOptions(), nullptr); }

namespace {

/// A text record with its dropped last line's warning (text_lines.hpp) passed to *warnings.
VectorRecord with_last_line_warning(VectorRecord record, std::vector<std::string>* warnings) {
  const auto dropped = record.header.find(kPartialLastLineKey);
  if (dropped != record.header.end() && warnings != nullptr) warnings->push_back(dropped->second);
  return record;
}

}  // namespace

VectorRecord read_record(const std::string& path, const LemiReadOptions& lemi_options,
                         std::vector<std::string>* warnings, const TextReadOptions& text_options) {
  switch (detect_record_format(path)) {
    case RecordFormat::kIaga2002:
      return with_last_line_warning(read_iaga2002(path, text_options), warnings);
    case RecordFormat::kCsv:
      break;
    case RecordFormat::kLemiBin:
      return read_lemi_bin(path, lemi_options, warnings);
    case RecordFormat::kLemiCompactFlash:
      return read_lemi_compact_flash(path, lemi_options, warnings);
    case RecordFormat::kLemi025Stream:
      return read_lemi025_stream(path, lemi_options, warnings);
    case RecordFormat::kCdf:
      return read_cdf_record(path);
  }
  return with_last_line_warning(read_csv_record(path, text_options), warnings);
}

}  // namespace magnetometer_insitu_calibration
