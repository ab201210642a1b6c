// SerialPortSource: termios raw 8N1, select() timeouts, disconnect detection, reopen.
#include "magnetometer_insitu_calibration/instrument/serial_port.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fcntl.h>
#include <sys/select.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

namespace magnetometer_insitu_calibration {

namespace {

bool baud_constant(int baud, speed_t& speed) {
  switch (baud) {
    case 1200: speed = B1200; return true;
    case 2400: speed = B2400; return true;
    case 4800: speed = B4800; return true;
    case 9600: speed = B9600; return true;
    case 19200: speed = B19200; return true;
    case 38400: speed = B38400; return true;
    case 57600: speed = B57600; return true;
    case 115200: speed = B115200; return true;
    case 230400: speed = B230400; return true;
    default: return false;
  }
}

std::string errno_text(const char* what) { return std::string(what) + ": " + std::strerror(errno); }

}  // namespace

bool SerialPortSource::is_supported_baud(int baud) {
  speed_t speed;
  return baud_constant(baud, speed);
}

SerialPortSource::SerialPortSource(const std::string& device, int baud)
    : device_(device), baud_(baud) {
  if (!is_supported_baud(baud))
    throw InputError("baud", std::to_string(baud) +
                                 " is not supported (1200 2400 4800 9600 19200 38400 57600 "
                                 "115200 230400)");
  open_port();
}

SerialPortSource::~SerialPortSource() {
  if (fd_ >= 0) ::close(fd_);
}

bool SerialPortSource::open_port() {
  const int fd = ::open(device_.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    last_error_ = errno_text(("open " + device_).c_str());
    return false;
  }
  termios tio{};
  if (::tcgetattr(fd, &tio) != 0) {
    last_error_ = errno_text((device_ + " is not a serial port: tcgetattr").c_str());
    ::close(fd);
    return false;
  }
  ::cfmakeraw(&tio);  // no echo, no line editing, no CR/LF translation, 8 data bits
  tio.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | CSTOPB | CRTSCTS);
  tio.c_cflag |= CS8 | CLOCAL | CREAD;  // 8N1, ignore modem lines, enable the receiver
  tio.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);  // no software flow control
  tio.c_cc[VMIN] = 0;  // select() does the waiting
  tio.c_cc[VTIME] = 0;
  speed_t speed = B57600;
  baud_constant(baud_, speed);
  if (::cfsetispeed(&tio, speed) != 0 || ::cfsetospeed(&tio, speed) != 0 ||
      ::tcsetattr(fd, TCSANOW, &tio) != 0) {
    last_error_ = errno_text(("configure " + device_).c_str());
    ::close(fd);
    return false;
  }
  struct stat st {};
  opened_rdev_ = ::fstat(fd, &st) == 0 ? st.st_rdev : 0;
  next_identity_check_ = std::chrono::steady_clock::now();
  fd_ = fd;
  last_error_.clear();
  return true;
}

void SerialPortSource::close_port(const std::string& why) {
  if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
    ++disconnects_;
  }
  last_error_ = why;
}

bool SerialPortSource::still_the_device() {
  next_identity_check_ = std::chrono::steady_clock::now() +
                         std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                             std::chrono::duration<double>(kIdentityCheckInterval_s));
  struct stat st {};
  if (::stat(device_.c_str(), &st) != 0) {
    // udev removes the node when a USB adapter is unplugged; a pty's link is left dangling.
    if (errno == ENOENT || errno == ENOTDIR) {
      close_port("device " + device_ + " is gone");
      return false;
    }
    return true;  // e.g. EACCES: cannot tell, keep reading
  }
  if (S_ISCHR(st.st_mode) && opened_rdev_ != 0 && st.st_rdev != opened_rdev_) {
    close_port(device_ + " now names another device (re-created or re-pointed link)");
    return false;
  }
  return true;
}

bool SerialPortSource::reopen() {
  if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
  }
  return open_port();
}

std::size_t SerialPortSource::read(std::uint8_t* buffer, std::size_t capacity, double timeout_s) {
  if (fd_ < 0 || capacity == 0) return 0;
  if (!(timeout_s > 0.0)) timeout_s = 0.0;
  fd_set readable;
  FD_ZERO(&readable);
  FD_SET(fd_, &readable);
  timeval tv{};
  tv.tv_sec = static_cast<time_t>(std::floor(timeout_s));
  tv.tv_usec = static_cast<suseconds_t>((timeout_s - std::floor(timeout_s)) * 1e6);
  const int ready = ::select(fd_ + 1, &readable, nullptr, nullptr, &tv);
  if (ready < 0) {
    if (errno != EINTR) close_port(errno_text("select"));
    return 0;
  }
  if (ready == 0) {
    still_the_device();  // quiet line: is the path still there, and still this device?
    return 0;
  }
  if (std::chrono::steady_clock::now() >= next_identity_check_ && !still_the_device()) return 0;
  const ssize_t n = ::read(fd_, buffer, capacity);
  if (n > 0) return static_cast<std::size_t>(n);
  if (n == 0) {
    close_port("end of file on " + device_ + " (hang-up)");
    return 0;
  }
  if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return 0;
  close_port(errno_text(("read " + device_).c_str()));
  return 0;
}

std::string SerialPortSource::describe() const {
  return "serial " + device_ + " " + std::to_string(baud_) + " 8N1";
}

}  // namespace magnetometer_insitu_calibration
