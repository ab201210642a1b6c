// Packet sources: StreamPacketSource (over a ByteSource), LemiBin and compact-flash files.
#include "magnetometer_insitu_calibration/instrument/packet_source.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <algorithm>
#include <filesystem>
#include <thread>

namespace magnetometer_insitu_calibration {

PacketSource::~PacketSource() = default;
bool PacketSource::at_end() const { return false; }
bool PacketSource::connected() const { return true; }
std::vector<std::string> PacketSource::take_warnings() { return {}; }
std::string PacketSource::connection_problem() const { return ""; }

// ---- StreamPacketSource ------------------------------------------------------------------------

StreamPacketSource::StreamPacketSource(std::unique_ptr<ByteSource> source, ChecksumMode checksum)
    : StreamPacketSource(std::move(source), [checksum] {
        StreamPacketSourceOptions options;
        options.parser.checksum = checksum;
        return options;
      }()) {}

StreamPacketSource::StreamPacketSource(std::unique_ptr<ByteSource> source,
                                       const StreamPacketSourceOptions& options)
    : source_(std::move(source)), options_(options), parser_(options.parser) {
  if (!source_) throw InputError("StreamPacketSource", "no byte source");
  chunk_.resize(std::max<std::size_t>(options_.read_chunk, 1));
  if (!source_->ok() && !source_->finished()) {
    // Never connected (device absent at start): retried by next(), not counted as a loss.
    disconnected_ = true;
    next_reopen_ = Clock::now();
    warnings_.push_back("not connected: " + source_->describe());
  }
}

std::optional<Lemi025Packet> StreamPacketSource::next(double timeout_s) {
  const Clock::time_point deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(
                         std::chrono::duration<double>(std::max(0.0, timeout_s)));
  do {
    if (!pending_.empty()) {
      Lemi025Packet packet = std::move(pending_.front());
      pending_.pop_front();
      return packet;
    }
    if (at_end_) return std::nullopt;
    if (source_->finished()) {
      parser_.flush();
      at_end_ = true;
      return std::nullopt;
    }
    if (!source_->ok()) {
      const Clock::time_point now = Clock::now();
      if (!disconnected_) {
        disconnected_ = true;
        ++disconnects_;
        parser_.flush();  // bytes on either side of a gap do not make a packet
        const std::string why = source_->problem();
        warnings_.push_back("disconnected: " + source_->describe() + (why.empty() ? "" : " (" + why + ")"));
        next_reopen_ = now;
      }
      if (now >= next_reopen_) {
        next_reopen_ = now + std::chrono::duration_cast<Clock::duration>(
                                 std::chrono::duration<double>(options_.reopen_interval_s));
        ++reopen_attempts_;
        if (source_->reopen()) {
          disconnected_ = false;
          ++reconnects_;
          warnings_.push_back("reconnected: " + source_->describe());
          continue;
        }
      }
      std::this_thread::sleep_until(std::min(deadline, next_reopen_));
      continue;
    }
    const double remaining_s =
        std::max(0.0, std::chrono::duration<double>(deadline - Clock::now()).count());
    const std::size_t got = source_->read(chunk_.data(), chunk_.size(), remaining_s);
    if (got > 0)
      for (Lemi025Packet& p : parser_.feed(chunk_.data(), got)) pending_.push_back(std::move(p));
  } while (!pending_.empty() || Clock::now() < deadline);
  return std::nullopt;
}

PacketSourceStats StreamPacketSource::stats() const {
  PacketSourceStats s;
  s.parser = parser_.stats();
  s.disconnects = disconnects_;
  s.reconnects = reconnects_;
  s.reopen_attempts = reopen_attempts_;
  return s;
}

std::string StreamPacketSource::describe() const {
  return "LEMI-025 stream from " + source_->describe() + ", checksum " +
         checksum_mode_name(options_.parser.checksum);
}

std::vector<std::string> StreamPacketSource::take_warnings() {
  std::vector<std::string> taken = std::move(warnings_);
  warnings_.clear();
  for (std::string& w : parser_.take_warnings()) taken.push_back(std::move(w));
  return taken;
}

// ---- Recorded sources --------------------------------------------------------------------------

std::optional<Lemi025Packet> RecordedPacketSource::next(double /*timeout_s*/) {
  if (index_ >= packets_.size()) return std::nullopt;
  return packets_[index_++];
}

std::vector<std::string> RecordedPacketSource::take_warnings() {
  std::vector<std::string> taken = std::move(warnings_);
  warnings_.clear();
  return taken;
}

void RecordedPacketSource::set_packets(std::vector<Lemi025Packet> packets,
                                       std::vector<std::string> warnings,
                                       std::string description) {
  packets_ = std::move(packets);
  warnings_ = std::move(warnings);
  description_ = std::move(description);
  stats_.parser.packets = packets_.size();
  stats_.parser.resyncs = warnings_.size();
  for (std::size_t i = 1; i < packets_.size(); ++i)
    if (packets_[i].gps_time_s != packets_[i - 1].gps_time_s + 1.0) ++stats_.parser.time_jumps;
}

LemiBinPacketSource::LemiBinPacketSource(const std::string& path, const LemiReadOptions& options) {
  std::vector<std::string> warnings;
  LemiBinFile file = read_lemi_bin_file(path, options, &warnings);
  std::vector<Lemi025Packet> packets;
  packets.reserve(file.records.size());
  for (const LemiBinRecord& r : file.records) {
    packets.push_back(r.packet);
    pc_times_s_.push_back(r.pc_time_s);
  }
  const std::uint64_t size = std::filesystem::file_size(path);
  const std::uint64_t header = file.header_line.empty() ? 0 : file.records.front().offset;
  stats_.parser.bytes_fed = size;
  stats_.parser.bytes_skipped = size - header - kLemiBinRecordSize * packets.size();
  set_packets(std::move(packets), std::move(warnings), "LemiBin file " + path);
}

CompactFlashPacketSource::CompactFlashPacketSource(const std::string& path) {
  std::vector<std::string> warnings;
  const std::vector<LemiFlashBlock> blocks = read_lemi_flash_blocks(path, &warnings);
  std::vector<Lemi025Packet> packets;
  packets.reserve(3 * blocks.size());
  for (const LemiFlashBlock& block : blocks)
    for (int s = 0; s < 3; ++s) packets.push_back(lemi_flash_block_second(block, s));
  stats_.parser.bytes_fed = std::filesystem::file_size(path);
  stats_.parser.bytes_skipped = stats_.parser.bytes_fed - kLemiFlashBlockSize * blocks.size();
  set_packets(std::move(packets), std::move(warnings), "LEMI compact-flash image " + path);
}

}  // namespace magnetometer_insitu_calibration
