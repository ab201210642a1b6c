// A serial port as a ByteSource: POSIX termios, raw 8N1, no flow control, select() timeouts.
// A pseudo-terminal slave (or a symlink to one, as made by lemi025_simulator) is a serial port
// too, which is how the driver is tested without hardware.
//
// Disconnection: read() marks the port disconnected (ok() false, the descriptor closed) when
// the device reports end of file (hang-up), an error such as EIO (USB adapter unplugged, pty
// master closed) or ENXIO/ENODEV, or when, on a timeout, the device path no longer exists.
// reopen() then tries to open the same path again; the caller decides how often.
//
// The path is followed, not the device first opened: when it names ANOTHER device than the one
// open (a symlink re-pointed: a pty re-created by socat, ser2net or lemi025_simulator, or a stale
// link whose pty number the kernel gave to someone else's pty and that the instrument's new pty
// replaced), read() marks the port disconnected too, so that reopen() follows the path. Checked
// when the line is quiet (a read timeout) and at least every kIdentityCheckInterval_s while
// bytes flow.
#pragma once

#include "magnetometer_insitu_calibration/instrument/byte_source.hpp"

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <string>

namespace magnetometer_insitu_calibration {

class SerialPortSource : public ByteSource {
 public:
  /// Baud rates accepted by the constructor.
  static bool is_supported_baud(int baud);

  /// Opens `device` (e.g. "/dev/ttyUSB0") raw 8N1 at `baud` (LEMI-025: 57600 by default, some
  /// units 19200). Throws InputError("baud", ...) for an unsupported rate. A device that
  /// cannot be opened is not an exception: ok() is false, last_error() says why, and
  /// reopen() retries (the adapter may be plugged in later).
  explicit SerialPortSource(const std::string& device, int baud = 57600);
  ~SerialPortSource() override;
  SerialPortSource(const SerialPortSource&) = delete;
  SerialPortSource& operator=(const SerialPortSource&) = delete;

  std::size_t read(std::uint8_t* buffer, std::size_t capacity, double timeout_s) override;
  bool ok() const override { return fd_ >= 0; }
  bool reopen() override;
  std::string describe() const override;

  const std::string& device() const { return device_; }
  int baud() const { return baud_; }
  /// Why the port is closed (or the last problem), "" if none.
  const std::string& last_error() const { return last_error_; }
  std::string problem() const override { return last_error_; }
  /// Longest time between two checks that the path still names the open device, s.
  static constexpr double kIdentityCheckInterval_s = 1.0;
  /// Times an open port was lost.
  std::uint64_t disconnects() const { return disconnects_; }

 private:
  bool open_port();
  void close_port(const std::string& why);
  /// Whether device_ still names the open device; closes the port (why) when it does not.
  bool still_the_device();

  std::string device_;
  int baud_;
  int fd_ = -1;
  dev_t opened_rdev_ = 0;   ///< device number of the open device (fstat st_rdev)
  std::chrono::steady_clock::time_point next_identity_check_{};
  std::string last_error_;
  std::uint64_t disconnects_ = 0;
};

}  // namespace magnetometer_insitu_calibration
