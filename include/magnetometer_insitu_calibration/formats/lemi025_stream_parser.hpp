// Incremental parser of a raw LEMI-025 byte stream (serial port, or a capture of one): feed it
// byte chunks of any size, it returns whole packets and keeps counters of what it skipped.
//
// Synchronisation rule (the frame: check_lemi025_frame). A packet is accepted at a position when
//   1. bytes 0-3 are "L025" or "L036",
//   2. bytes 5-10 are a valid BCD date and time,
//   3. (default) mode is 1..3, flash free <= 100 %, GPS status is A, P, O or S,
//   4. the checksum matches, if a ChecksumMode other than kNone is selected.
// 1-3 are the frame of a packet: if they fail, the candidate is not a packet (a tag inside
// garbage, or a packet shortened by dropped bytes whose tail -- status bytes -- has moved) and
// the parser skips one byte and searches for the next tag. If only 4 fails, the 153 bytes are a
// packet with a damaged byte: they are consumed and counted in checksum_errors (not in
// bytes_skipped).
// Readings do not decide the frame: a framed packet (and, with sum8/xor8, checksum-verified, i.e.
// intact as sent) whose readings include implausible ones (not finite, or a component beyond
// +-Lemi025Plausibility::max_abs_variation_nT, e.g. a failing ADC) is returned with those
// readings -- all three components -- set to NaN (lemi_mark_implausible_readings), counted in
// implausible_readings; its good readings are kept. Only with checksum kNone AND
// check_status_bytes = false (nothing else checks the packet's tail) must every reading be
// plausible for the frame, as before.
// Time continuity is not a condition of acceptance (a real clock step or a lost packet must not
// stall the stream); a packet whose GPS second is not the previous accepted packet's + 1 s is
// accepted and counted in time_jumps (the driver decides what to publish).
//
// A partial packet at the end of a chunk waits for the next chunk; flush() declares the stream
// ended (or interrupted, e.g. a serial disconnect) and counts what is left as skipped.
#pragma once

#include "magnetometer_insitu_calibration/formats/lemi025_packet.hpp"

#include <cstddef>
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// What the parser has seen since construction (or reset_stats()).
struct Lemi025ParserStats {
  std::uint64_t packets = 0;          ///< packets accepted and returned
  std::uint64_t checksum_errors = 0;  ///< well-formed packets dropped for a checksum mismatch
  std::uint64_t resyncs = 0;          ///< runs of skipped bytes (each loss of synchronisation)
  std::uint64_t bytes_skipped = 0;    ///< bytes that belonged to no packet
  std::uint64_t time_jumps = 0;       ///< accepted packets not 1 s after the previous one
  std::uint64_t implausible_readings = 0;  ///< readings of accepted packets set to NaN (not finite / out of range)
  std::uint64_t bytes_fed = 0;        ///< bytes given to feed()
};

struct Lemi025ParserOptions {
  ChecksumMode checksum = ChecksumMode::kNone;
  Lemi025Plausibility plausibility;
  std::size_t max_warnings = 1000;  ///< warnings kept until take_warnings(); older are dropped
};

/// One accepted packet with its place in the stream.
struct Lemi025StreamPacket {
  Lemi025Packet packet;
  std::uint64_t offset = 0;  ///< stream offset of its first byte (bytes fed before it)
};

class Lemi025StreamParser {
 public:
  explicit Lemi025StreamParser(ChecksumMode checksum = ChecksumMode::kNone);
  explicit Lemi025StreamParser(const Lemi025ParserOptions& options);

  /// Appends bytes and returns the packets completed by them, in stream order.
  std::vector<Lemi025Packet> feed(const std::uint8_t* data, std::size_t size);
  std::vector<Lemi025Packet> feed(const std::vector<std::uint8_t>& data) {
    return feed(data.data(), data.size());
  }
  /// As feed(), with each packet's stream offset.
  std::vector<Lemi025StreamPacket> feed_with_offsets(const std::uint8_t* data, std::size_t size);

  /// End of stream or interruption: the bytes still buffered (a partial packet) are counted as
  /// skipped, and the next packet starts a new sequence (no time jump counted across it).
  void flush();

  /// Bytes buffered waiting for the rest of a packet.
  std::size_t buffered() const { return buffer_.size() - start_; }
  const Lemi025ParserStats& stats() const { return stats_; }
  void reset_stats() { stats_ = Lemi025ParserStats{}; }
  const Lemi025ParserOptions& options() const { return options_; }

  /// Messages "stream byte <offset>: <what>" for every skipped run and checksum error since
  /// the last call (at most options.max_warnings).
  std::vector<std::string> take_warnings();

 private:
  void parse(std::vector<Lemi025StreamPacket>& out);
  void skip(std::size_t count, const std::string& reason);
  void end_skip_run();
  void warn(const std::string& message);
  std::uint64_t offset_of(std::size_t index) const { return base_offset_ + index; }

  Lemi025ParserOptions options_;
  Lemi025ParserStats stats_;
  std::vector<std::uint8_t> buffer_;
  std::size_t start_ = 0;            ///< first unparsed byte in buffer_
  std::uint64_t base_offset_ = 0;    ///< stream offset of buffer_[0]
  bool in_skip_run_ = false;
  std::uint64_t skip_run_offset_ = 0;
  std::uint64_t skip_run_bytes_ = 0;
  std::string skip_run_reason_;
  bool have_previous_ = false;
  double previous_time_s_ = 0.0;
  std::deque<std::string> warnings_;
};

}  // namespace magnetometer_insitu_calibration
