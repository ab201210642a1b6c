// Raw capture of the LEMI-025 serial byte stream to a 10 Hz VectorRecord.
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/lemi025_stream_parser.hpp"
#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"

#include <fstream>

namespace magnetometer_insitu_calibration {

VectorRecord read_lemi025_stream(const std::string& path, const LemiReadOptions& options,
                                 std::vector<std::string>* warnings) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "cannot open");
  Lemi025ParserOptions parser_options;
  parser_options.checksum = options.checksum;
  parser_options.plausibility = options.plausibility;
  parser_options.max_warnings = static_cast<std::size_t>(-1);
  Lemi025StreamParser parser(parser_options);
  std::vector<Lemi025Packet> packets;
  std::vector<std::uint8_t> chunk(1 << 16);
  while (in) {
    in.read(reinterpret_cast<char*>(chunk.data()), static_cast<std::streamsize>(chunk.size()));
    const std::size_t got = static_cast<std::size_t>(in.gcount());
    if (got == 0) break;
    for (Lemi025Packet& p : parser.feed(chunk.data(), got)) packets.push_back(std::move(p));
  }
  if (in.bad()) throw InputError(path, "read error");
  parser.flush();
  if (warnings != nullptr) {
    // The parser says "stream byte N"; in a file that is the file offset.
    for (const std::string& w : parser.take_warnings())
      warnings->push_back(path + " " + w.substr(w.rfind("stream ", 0) == 0 ? 7 : 0));
  }
  if (packets.empty()) throw InputError(path, "no valid LEMI-025 packet in the byte stream");
  std::vector<std::string> record_warnings;
  VectorRecord record = lemi025_packets_to_record(packets, options, &record_warnings);
  if (warnings != nullptr)
    for (const std::string& w : record_warnings) warnings->push_back(path + ": " + w);
  record.source = path;
  record.header["format"] = "LEMI-025 raw byte stream";
  const Lemi025ParserStats& s = parser.stats();
  record.header["packets"] = std::to_string(s.packets);
  record.header["checksum_errors"] = std::to_string(s.checksum_errors);
  record.header["bytes_skipped"] = std::to_string(s.bytes_skipped);
  record.header["time_jumps"] = std::to_string(s.time_jumps);
  return record;
}

}  // namespace magnetometer_insitu_calibration
