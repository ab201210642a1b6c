// libFuzzer target: Lemi025StreamParser::feed / feed_with_offsets / flush (serial byte stream).
// Input: byte 0 = options (bits 0-1 checksum mode: 0 none, 1 sum8, 2 xor8, 3 none;
// bit 2: do not check status bytes; bit 3: max_warnings 2 instead of 1000), byte 1 = seed of the
// chunk sizes; the rest is the stream, fed in chunks of 1..256 bytes as a serial port would.
// Checks:
//  - never more than one partial packet buffered (bounded memory on an endless bad line);
//  - every returned packet lies in the stream at its offset, packets do not overlap and decode
//    (decode_lemi025_packet with the same options) to the returned values;
//  - byte accounting after flush(): 153 * (packets + checksum_errors) + bytes_skipped == bytes fed;
//  - the packets do not depend on the chunking: one feed() of the whole stream gives the same;
//  - at most max_warnings warnings are kept.
#include "fuzz_common.hpp"

#include "magnetometer_insitu_calibration/formats/lemi025_stream_parser.hpp"

#include <vector>

using namespace magnetometer_insitu_calibration;

namespace {

bool same_packet(const Lemi025Packet& a, const Lemi025Packet& b) {
  return a.model == b.model && a.station == b.station && a.gps_time_s == b.gps_time_s &&
         ((a.variation_nT.array() == b.variation_nT.array()) ||
          (a.variation_nT.array().isNaN() && b.variation_nT.array().isNaN()))
             .all() &&
         a.bias_nT == b.bias_nT && a.checksum == b.checksum &&
         a.mode == b.mode && a.gps_status == b.gps_status && a.supply_V == b.supply_V;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (!mic_fuzz::within_bounds(data, size, false)) return -1;
  if (size < 2) return 0;
  const std::uint8_t config = data[0];
  std::uint32_t seed = data[1] * 2654435761u + 1u;
  const std::uint8_t* stream = data + 2;
  const std::size_t n = size - 2;

  Lemi025ParserOptions options;
  const int checksum = config & 3;
  options.checksum = checksum == 1 ? ChecksumMode::kSum8
                     : checksum == 2 ? ChecksumMode::kXor8
                                     : ChecksumMode::kNone;
  options.plausibility.check_status_bytes = (config & 4) == 0;
  options.max_warnings = (config & 8) ? 2 : 1000;

  try {
    Lemi025StreamParser parser(options);
    std::vector<Lemi025StreamPacket> chunked;
    std::size_t pos = 0;
    while (pos < n) {
      seed = seed * 1103515245u + 12345u;
      const std::size_t chunk = std::min<std::size_t>(n - pos, 1 + (seed >> 16) % 256);
      for (auto& p : parser.feed_with_offsets(stream + pos, chunk)) chunked.push_back(std::move(p));
      pos += chunk;
      FUZZ_CHECK(parser.buffered() < kLemi025PacketSize,
                 "parser buffers " + std::to_string(parser.buffered()) + " bytes");
    }
    parser.flush();
    FUZZ_CHECK(parser.buffered() == 0, "bytes left after flush");
    const Lemi025ParserStats& s = parser.stats();
    FUZZ_CHECK(s.bytes_fed == n, "bytes_fed");
    FUZZ_CHECK(s.packets == chunked.size(), "packets counter");
    FUZZ_CHECK(kLemi025PacketSize * (s.packets + s.checksum_errors) + s.bytes_skipped == n,
               "byte accounting: packets " + std::to_string(s.packets) + ", checksum errors " +
                   std::to_string(s.checksum_errors) + ", skipped " +
                   std::to_string(s.bytes_skipped) + ", fed " + std::to_string(n));
    for (std::size_t i = 0; i < chunked.size(); ++i) {
      const std::uint64_t off = chunked[i].offset;
      FUZZ_CHECK(off + kLemi025PacketSize <= n, "packet offset beyond the stream");
      if (i > 0) FUZZ_CHECK(off >= chunked[i - 1].offset + kLemi025PacketSize, "packets overlap");
      const Lemi025Packet direct =
          decode_lemi025_packet(stream + off, options.checksum, options.plausibility);
      FUZZ_CHECK(same_packet(direct, chunked[i].packet), "packet differs from the bytes at its offset");
    }
    FUZZ_CHECK(parser.take_warnings().size() <= options.max_warnings, "too many warnings kept");
    FUZZ_CHECK(parser.take_warnings().empty(), "take_warnings does not clear");

    Lemi025StreamParser whole(options);
    const std::vector<Lemi025StreamPacket> at_once = whole.feed_with_offsets(stream, n);
    whole.flush();
    FUZZ_CHECK(at_once.size() == chunked.size(), "chunking changes the number of packets: " +
                                                     std::to_string(at_once.size()) + " vs " +
                                                     std::to_string(chunked.size()));
    for (std::size_t i = 0; i < at_once.size(); ++i)
      FUZZ_CHECK(at_once[i].offset == chunked[i].offset, "chunking changes packet offsets");
    FUZZ_CHECK(whole.stats().bytes_skipped == s.bytes_skipped &&
                   whole.stats().checksum_errors == s.checksum_errors &&
                   whole.stats().time_jumps == s.time_jumps,
               "chunking changes the statistics");
  } catch (...) {
    // The parser documents no exception at all: bad bytes are skipped and counted.
    mic_fuzz::unexpected_exception(__FILE__, __LINE__);
  }
  return 0;
}
