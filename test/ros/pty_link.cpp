// PtyLink: see pty_link.hpp.
#include "pty_link.hpp"

#include <gtest/gtest.h>

#include <fcntl.h>
#include <stdlib.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

namespace magnetometer_insitu_calibration {
namespace test {

PtyLink::PtyLink(std::string link) : link_(std::move(link)) {}

PtyLink::~PtyLink() {
  close();
  for (int fd : replaced_) ::close(fd);
}

std::string PtyLink::open() {
  master_ = ::posix_openpt(O_RDWR | O_NOCTTY);
  if (master_ < 0 || ::grantpt(master_) != 0 || ::unlockpt(master_) != 0) {
    return std::string("cannot create a pty: ") + std::strerror(errno);
  }
  const std::string slave_name = ::ptsname(master_);
  slave_ = ::open(slave_name.c_str(), O_RDWR | O_NOCTTY);
  if (slave_ < 0) return slave_name + ": " + std::strerror(errno);
  termios tio{};
  ::tcgetattr(slave_, &tio);
  ::cfmakeraw(&tio);
  ::tcsetattr(slave_, TCSANOW, &tio);
  const std::string tmp = link_ + ".tmp";
  ::unlink(tmp.c_str());
  if (::symlink(slave_name.c_str(), tmp.c_str()) != 0 || ::rename(tmp.c_str(), link_.c_str()) != 0) {
    return "cannot point " + link_ + " at " + slave_name + ": " + std::strerror(errno);
  }
  return "";
}

std::string PtyLink::replace() {
  replaced_.push_back(master_);
  replaced_.push_back(slave_);
  master_ = slave_ = -1;
  return open();
}

void PtyLink::close() {
  ::unlink(link_.c_str());
  if (slave_ >= 0) ::close(slave_);
  if (master_ >= 0) ::close(master_);
  slave_ = master_ = -1;
}

void PtyLink::write(const std::vector<std::uint8_t>& bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(master_, bytes.data() + done, bytes.size() - done);
    if (n <= 0) {
      ADD_FAILURE() << "write to the pty " << link_ << ": " << std::strerror(errno);
      return;
    }
    done += static_cast<std::size_t>(n);
    bytes_written_ += static_cast<std::uint64_t>(n);
  }
}

}  // namespace test
}  // namespace magnetometer_insitu_calibration
