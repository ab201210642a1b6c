// ByteSource defaults and FileByteSource (recorded byte stream, optional real-time pacing).
#include "magnetometer_insitu_calibration/instrument/byte_source.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <algorithm>
#include <cmath>
#include <thread>

namespace magnetometer_insitu_calibration {

ByteSource::~ByteSource() = default;
bool ByteSource::ok() const { return true; }
bool ByteSource::reopen() { return ok(); }
bool ByteSource::finished() const { return false; }
std::string ByteSource::describe() const { return "byte source"; }
std::string ByteSource::problem() const { return ""; }

FileByteSource::FileByteSource(const std::string& path, const FileByteSourceOptions& options)
    : path_(path), options_(options), in_(path, std::ios::binary) {
  if (!in_) throw InputError(path, "cannot open");
  if (options_.max_chunk == 0) options_.max_chunk = 1;
  if (!(options_.bytes_per_second >= 0.0))
    throw InputError(path, "bytes_per_second must be >= 0");
}

bool FileByteSource::reopen() {
  in_.close();
  in_.clear();
  in_.open(path_, std::ios::binary);
  at_end_ = !in_;
  clock_started_ = false;
  delivered_ = 0;
  return ok();
}

std::size_t FileByteSource::read(std::uint8_t* buffer, std::size_t capacity, double timeout_s) {
  if (finished() || capacity == 0) return 0;
  if (!options_.loop && in_.peek() == std::char_traits<char>::eof()) {
    at_end_ = true;  // known now rather than after the pacing wait
    return 0;
  }
  std::size_t want = std::min(capacity, options_.max_chunk);
  if (options_.bytes_per_second > 0.0) {
    const Clock::time_point now = Clock::now();
    if (!clock_started_) {
      clock_started_ = true;
      start_ = now;
      delivered_ = 0;
    }
    // Bytes due by `when`: one every 1/rate s, the first at once.
    auto due_at = [&](Clock::time_point when) {
      const double elapsed = std::chrono::duration<double>(when - start_).count();
      return static_cast<std::uint64_t>(std::floor(elapsed * options_.bytes_per_second)) + 1;
    };
    std::uint64_t due = due_at(now);
    if (due <= delivered_) {
      // Wait for the next byte, or give up at the timeout.
      const double next_s = static_cast<double>(delivered_) / options_.bytes_per_second;
      const Clock::time_point next =
          start_ + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(next_s));
      const Clock::time_point deadline =
          now + std::chrono::duration_cast<Clock::duration>(
                    std::chrono::duration<double>(std::max(0.0, timeout_s)));
      if (next > deadline) {
        std::this_thread::sleep_until(deadline);
        return 0;
      }
      std::this_thread::sleep_until(next);
      due = std::max(due_at(Clock::now()), delivered_ + 1);
    }
    want = static_cast<std::size_t>(std::min<std::uint64_t>(want, due - delivered_));
  }
  std::size_t got = 0;
  while (got == 0) {
    in_.read(reinterpret_cast<char*>(buffer), static_cast<std::streamsize>(want));
    got = static_cast<std::size_t>(in_.gcount());
    if (got < want) {
      // End of file: stop, or start again when looping.
      if (!options_.loop) {
        at_end_ = true;
        break;
      }
      in_.clear();
      in_.seekg(0);
      if (got == 0 && in_.peek() == std::char_traits<char>::eof()) {  // empty file
        at_end_ = true;
        options_.loop = false;
        break;
      }
    }
  }
  delivered_ += got;
  return got;
}

std::string FileByteSource::describe() const {
  std::string text = "file " + path_;
  if (options_.bytes_per_second > 0.0)
    text += " at " + std::to_string(static_cast<long>(options_.bytes_per_second)) + " bytes/s";
  if (options_.loop) text += " (looped)";
  return text;
}

}  // namespace magnetometer_insitu_calibration
