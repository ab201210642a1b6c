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
  /// Unplugged: removes the symlink (as udev removes a USB adapter's device links, and
  /// lemi025_simulator its link when it stops), then closes master and slave: a reader of the
  /// slave sees a hang-up. Leaving the link behind would leave it naming a pty number that the
  /// kernel gives to the next pty anyone opens (another test's, run beside this one).
  void close();
  /// Another pty appears under the same link (re-pointed atomically) while the current one
  /// stays open and silent (socat or a simulator re-created its pty): kept open until
  /// destruction, never written again. Returns "" or what failed.
  std::string replace();
  /// Writes every byte to the master; a failed write is a gtest failure (ADD_FAILURE).
  void write(const std::vector<std::uint8_t>& bytes);
  /// Bytes written by write() since construction, over every pty opened.
  std::uint64_t bytes_written() const { return bytes_written_; }
  const std::string& link() const { return link_; }

 private:
  std::string link_;
  int master_ = -1, slave_ = -1;
  std::uint64_t bytes_written_ = 0;
  std::vector<int> replaced_;  ///< master and slave of ptys replaced(), closed at destruction
};

}  // namespace test
}  // namespace magnetometer_insitu_calibration
