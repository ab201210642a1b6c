// Incremental LEMI-025 stream parser (synchronisation rule in the header).
#include "magnetometer_insitu_calibration/formats/lemi025_stream_parser.hpp"

#include "lemi_bytes.hpp"

#include <algorithm>

namespace magnetometer_insitu_calibration {

namespace {

constexpr std::size_t kTagSize = 4;
constexpr std::size_t kCompactThreshold = 1 << 16;

// True if the n (< 4) bytes at p could be the beginning of "L025" / "L036".
bool is_tag_prefix(const std::uint8_t* p, std::size_t n) {
  if (n >= 1 && p[0] != 'L') return false;
  if (n >= 2 && p[1] != '0') return false;
  if (n >= 3 && p[2] != '2' && p[2] != '3') return false;
  return true;
}

}  // namespace

Lemi025StreamParser::Lemi025StreamParser(ChecksumMode checksum) {
  options_.checksum = checksum;
}

Lemi025StreamParser::Lemi025StreamParser(const Lemi025ParserOptions& options)
    : options_(options) {}

std::vector<Lemi025Packet> Lemi025StreamParser::feed(const std::uint8_t* data, std::size_t size) {
  std::vector<Lemi025StreamPacket> found = feed_with_offsets(data, size);
  std::vector<Lemi025Packet> packets;
  packets.reserve(found.size());
  for (Lemi025StreamPacket& f : found) packets.push_back(std::move(f.packet));
  return packets;
}

std::vector<Lemi025StreamPacket> Lemi025StreamParser::feed_with_offsets(const std::uint8_t* data,
                                                                        std::size_t size) {
  stats_.bytes_fed += size;
  buffer_.insert(buffer_.end(), data, data + size);
  std::vector<Lemi025StreamPacket> out;
  parse(out);
  // Drop consumed bytes now and then rather than on every packet.
  if (start_ >= kCompactThreshold || start_ == buffer_.size()) {
    buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(start_));
    base_offset_ += start_;
    start_ = 0;
  }
  return out;
}

void Lemi025StreamParser::parse(std::vector<Lemi025StreamPacket>& out) {
  while (true) {
    const std::size_t size = buffer_.size();
    const std::size_t avail = size - start_;
    if (avail == 0) return;
    const std::uint8_t* p = buffer_.data() + start_;
    if (avail < kTagSize) {
      if (is_tag_prefix(p, avail)) return;  // may become a tag with the next chunk
      skip(1, "no packet tag");
      continue;
    }
    if (!lemi_detail::is_lemi_tag(p)) {
      // Skip to the next full tag, or to a tag prefix at the very end of the buffer.
      std::size_t q = start_ + 1;
      while (q + kTagSize <= size && !lemi_detail::is_lemi_tag(buffer_.data() + q)) ++q;
      if (q + kTagSize > size) {
        while (q < size && !is_tag_prefix(buffer_.data() + q, size - q)) ++q;
      }
      skip(q - start_, "no packet tag");
      continue;
    }
    if (avail < kLemi025PacketSize) return;  // wait for the rest of the packet

    const Lemi025Problem problem = check_lemi025_frame(p, options_.checksum, options_.plausibility);
    if (problem != Lemi025Problem::kOk) {
      // A tag that does not start a well-formed packet: garbage, or a packet cut short.
      skip(1, "tag at a non-packet: " + lemi025_problem_text(problem));
      continue;
    }
    end_skip_run();
    if (!lemi025_checksum_ok(p, options_.checksum)) {
      ++stats_.checksum_errors;
      warn("stream byte " + std::to_string(offset_of(start_)) + ": packet dropped, " +
           checksum_mode_name(options_.checksum) + " checksum mismatch");
      start_ += kLemi025PacketSize;
      continue;
    }
    Lemi025StreamPacket found{decode_lemi025_packet_unchecked(p), offset_of(start_)};
    const int implausible = lemi_mark_implausible_readings(found.packet.variation_nT, options_.plausibility);
    if (implausible > 0) {
      stats_.implausible_readings += static_cast<std::uint64_t>(implausible);
      warn("stream byte " + std::to_string(found.offset) + ": " + std::to_string(implausible) +
           " implausible readings set to NaN");
    }
    if (have_previous_ && found.packet.gps_time_s != previous_time_s_ + 1.0) {
      ++stats_.time_jumps;
      warn("stream byte " + std::to_string(found.offset) + ": time jump of " +
           std::to_string(found.packet.gps_time_s - previous_time_s_) + " s");
    }
    have_previous_ = true;
    previous_time_s_ = found.packet.gps_time_s;
    ++stats_.packets;
    start_ += kLemi025PacketSize;
    out.push_back(std::move(found));
  }
}

void Lemi025StreamParser::skip(std::size_t count, const std::string& reason) {
  if (!in_skip_run_) {
    in_skip_run_ = true;
    ++stats_.resyncs;
    skip_run_offset_ = offset_of(start_);
    skip_run_bytes_ = 0;
    skip_run_reason_ = reason;
  }
  stats_.bytes_skipped += count;
  skip_run_bytes_ += count;
  start_ += count;
}

void Lemi025StreamParser::end_skip_run() {
  if (!in_skip_run_) return;
  in_skip_run_ = false;
  warn("stream byte " + std::to_string(skip_run_offset_) + ": skipped " +
       std::to_string(skip_run_bytes_) + " bytes (" + skip_run_reason_ + ")");
}

void Lemi025StreamParser::flush() {
  const std::size_t left = buffer_.size() - start_;
  if (left > 0) {
    if (in_skip_run_) {
      skip(left, "");
    } else {
      skip(left, "incomplete packet at end of stream");
    }
  }
  end_skip_run();
  base_offset_ += buffer_.size();
  buffer_.clear();
  start_ = 0;
  have_previous_ = false;
}

void Lemi025StreamParser::warn(const std::string& message) {
  if (options_.max_warnings == 0) return;
  if (warnings_.size() >= options_.max_warnings) warnings_.pop_front();
  warnings_.push_back(message);
}

std::vector<std::string> Lemi025StreamParser::take_warnings() {
  std::vector<std::string> taken(warnings_.begin(), warnings_.end());
  warnings_.clear();
  return taken;
}

}  // namespace magnetometer_insitu_calibration
