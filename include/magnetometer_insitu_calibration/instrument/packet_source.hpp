// Where LEMI-025 packets come from, behind one interface: a live or recorded byte stream
// (StreamPacketSource over any ByteSource), a LemiBin file, or a compact-flash card image.
// The driver node asks next(timeout) in its loop and publishes whatever it gets.
#pragma once

#include "magnetometer_insitu_calibration/instrument/byte_source.hpp"
#include "magnetometer_insitu_calibration/formats/lemi025_packet.hpp"
#include "magnetometer_insitu_calibration/formats/lemi025_stream_parser.hpp"
#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"

#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// Counters of a packet source. For file sources, parser.bytes_skipped counts the bytes of bad
/// records/blocks and parser.resyncs the places they were found.
struct PacketSourceStats {
  Lemi025ParserStats parser;     ///< packets, checksum_errors, resyncs, bytes_skipped, time_jumps
  std::uint64_t disconnects = 0; ///< connection losses of the byte source
  std::uint64_t reconnects = 0;  ///< successful reopen()s after a loss
  std::uint64_t reopen_attempts = 0;  ///< reopen()s tried while disconnected, successful or not
};

class PacketSource {
 public:
  virtual ~PacketSource();
  /// The next packet, waiting at most timeout_s seconds; nullopt on timeout, while the
  /// connection is down, or at the end (then at_end() is true).
  virtual std::optional<Lemi025Packet> next(double timeout_s) = 0;
  /// True when no packet will ever come again (end of a recording).
  virtual bool at_end() const;
  /// False while the underlying connection is lost (serial port unplugged, ...).
  virtual bool connected() const;
  virtual PacketSourceStats stats() const = 0;
  virtual std::string describe() const = 0;
  /// Problems seen since the last call ("stream byte N: skipped ...", "disconnected: ...").
  virtual std::vector<std::string> take_warnings();
  /// While disconnected: why (the device's last error, e.g. "open /dev/ttyUSB0: No such file
  /// or directory"); "" when connected or nothing is known.
  virtual std::string connection_problem() const;
};

struct StreamPacketSourceOptions {
  Lemi025ParserOptions parser;     ///< checksum mode and plausibility
  double reopen_interval_s = 1.0;  ///< time between reopen() attempts while disconnected, s
  std::size_t read_chunk = 1024;   ///< bytes asked of the ByteSource per read
};

/// Packets parsed from a ByteSource (serial port or recorded stream). While the source is
/// disconnected, next() tries reopen() at once and then every reopen_interval_s (a fixed
/// interval: trying to open a device costs nothing, and the data come back at most one interval
/// after the device does); a partial packet buffered at the disconnection is discarded (counted
/// as skipped).
class StreamPacketSource : public PacketSource {
 public:
  /// Throws InputError("StreamPacketSource", ...) if `source` is null.
  explicit StreamPacketSource(std::unique_ptr<ByteSource> source,
                              ChecksumMode checksum = ChecksumMode::kNone);
  StreamPacketSource(std::unique_ptr<ByteSource> source, const StreamPacketSourceOptions& options);

  std::optional<Lemi025Packet> next(double timeout_s) override;
  bool at_end() const override { return at_end_; }
  bool connected() const override { return source_->ok(); }
  PacketSourceStats stats() const override;
  std::string describe() const override;
  std::vector<std::string> take_warnings() override;
  std::string connection_problem() const override { return source_->ok() ? std::string() : source_->problem(); }

  ByteSource& byte_source() { return *source_; }

 private:
  using Clock = std::chrono::steady_clock;
  std::unique_ptr<ByteSource> source_;
  StreamPacketSourceOptions options_;
  Lemi025StreamParser parser_;
  std::deque<Lemi025Packet> pending_;
  std::vector<std::uint8_t> chunk_;
  std::vector<std::string> warnings_;
  bool at_end_ = false;
  bool disconnected_ = false;
  Clock::time_point next_reopen_{};
  std::uint64_t disconnects_ = 0;
  std::uint64_t reconnects_ = 0;
  std::uint64_t reopen_attempts_ = 0;
};

/// Packets read from a file at construction, handed out one per next() (no waiting).
class RecordedPacketSource : public PacketSource {
 public:
  std::optional<Lemi025Packet> next(double timeout_s) override;
  bool at_end() const override { return index_ >= packets_.size(); }
  PacketSourceStats stats() const override { return stats_; }
  std::string describe() const override { return description_; }
  std::vector<std::string> take_warnings() override;
  /// All packets of the file, in file order.
  const std::vector<Lemi025Packet>& packets() const { return packets_; }

 protected:
  RecordedPacketSource() = default;
  /// Stores the packets, counts time jumps, takes the reader's warnings.
  void set_packets(std::vector<Lemi025Packet> packets, std::vector<std::string> warnings,
                   std::string description);

  PacketSourceStats stats_;

 private:
  std::vector<Lemi025Packet> packets_;
  std::size_t index_ = 0;
  std::vector<std::string> warnings_;
  std::string description_;
};

/// The packets of a LemiBin file. Throws InputError as read_lemi_bin_file.
class LemiBinPacketSource : public RecordedPacketSource {
 public:
  explicit LemiBinPacketSource(const std::string& path, const LemiReadOptions& options = {});
  /// PC clock (UNIX s) of each packet, parallel to packets().
  const std::vector<double>& pc_times_s() const { return pc_times_s_; }

 private:
  std::vector<double> pc_times_s_;
};

/// The readings of a compact-flash card image as packet-like groups of ten (one per second,
/// see lemi_flash_block_second). Throws InputError as read_lemi_flash_blocks.
class CompactFlashPacketSource : public RecordedPacketSource {
 public:
  explicit CompactFlashPacketSource(const std::string& path);
};

}  // namespace magnetometer_insitu_calibration
