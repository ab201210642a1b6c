// A pseudo-terminal playing an instrument's serial port in the driver rostests
// (test_lemi025_driver, test_faults_driver): the test writes bytes into the pty master, the driver
// under test opens the slave through a symlink, exactly as it would open /dev/ttyUSB0.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {
namespace test {

class PtyLink {
 public:
  /// `link`: path of the symlink the driver's ~device names (created by open()).
  explicit PtyLink(std::string link);
  /// Closes the pty and removes the symlink.
  ~PtyLink();
  PtyLink(const PtyLink&) = delete;
  PtyLink& operator=(const PtyLink&) = delete;

  /// Creates a pty, keeps its slave open (raw mode: bytes wait in its queue until the driver
  /// reads them) and points the symlink at it atomically (symlink + rename). Returns "" or what
  /// failed.
  std::string open();
  /// Closes master and slave: a reader of the slave sees a hang-up (serial cable unplugged).
  void close();
  /// Writes every byte to the master; a failed write is a gtest failure (ADD_FAILURE).
  void write(const std::vector<std::uint8_t>& bytes);
  const std::string& link() const { return link_; }

 private:
  std::string link_;
  int master_ = -1, slave_ = -1;
};

}  // namespace test
}  // namespace magnetometer_insitu_calibration
