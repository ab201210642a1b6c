// Where raw instrument bytes come from: a serial port (serial_port.hpp) or a recorded byte
// stream (FileByteSource), behind one interface so the packet layer and the driver node do not
// care which.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <fstream>
#include <string>

namespace magnetometer_insitu_calibration {

class ByteSource {
 public:
  virtual ~ByteSource();

  /// Reads up to `capacity` bytes into `buffer`, waiting at most `timeout_s` seconds for the
  /// first one (0: do not wait). Returns how many were read: 0 on timeout, when the connection
  /// is lost (ok() becomes false) or at the end of a recording (finished() becomes true).
  virtual std::size_t read(std::uint8_t* buffer, std::size_t capacity, double timeout_s) = 0;
  /// False while disconnected or exhausted; read() then returns 0 at once.
  virtual bool ok() const;
  /// Tries to connect again (serial: reopen the device; file: start again from the beginning).
  /// Returns ok() afterwards.
  virtual bool reopen();
  /// True when no byte will ever come again (a recording read to its end). A disconnected
  /// serial port is not finished: it may come back after reopen().
  virtual bool finished() const;
  /// Human-readable origin, e.g. "serial /dev/ttyUSB0 57600 8N1", for logs and diagnostics.
  virtual std::string describe() const;
  /// Why the source is disconnected or the last reopen() failed ("" if nothing to say), for
  /// logs and diagnostics.
  virtual std::string problem() const;
};

struct FileByteSourceOptions {
  /// Pacing: at most this many bytes per second since the first read(), so a recording plays
  /// back like the live instrument (a LEMI-025 sends 153 bytes/s). 0: as fast as read().
  double bytes_per_second = 0.0;
  /// At the end of the file start again from its beginning (an endless replay).
  bool loop = false;
  /// Largest number of bytes one read() returns (small values exercise split packets).
  std::size_t max_chunk = 4096;
};

/// A recorded byte stream (e.g. a capture of a LEMI-025 serial port) read from a file.
class FileByteSource : public ByteSource {
 public:
  /// Throws InputError(path, "cannot open") if the file cannot be read.
  explicit FileByteSource(const std::string& path, const FileByteSourceOptions& options = {});

  std::size_t read(std::uint8_t* buffer, std::size_t capacity, double timeout_s) override;
  bool ok() const override { return !finished(); }
  bool reopen() override;  ///< rewinds to the first byte (and restarts the pacing clock)
  bool finished() const override { return at_end_ && !options_.loop; }
  std::string describe() const override;

  std::uint64_t bytes_delivered() const { return delivered_; }

 private:
  using Clock = std::chrono::steady_clock;
  std::string path_;
  FileByteSourceOptions options_;
  std::ifstream in_;
  bool at_end_ = false;
  bool clock_started_ = false;
  Clock::time_point start_;
  std::uint64_t delivered_ = 0;  ///< since the pacing clock started
};

}  // namespace magnetometer_insitu_calibration
