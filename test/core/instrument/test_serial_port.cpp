// SerialPortSource on a pseudo-terminal (a real tty: termios applies), disconnect and reopen;
// FileByteSource pacing; StreamPacketSource over both.
#include "magnetometer_insitu_calibration/instrument/byte_source.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/instrument/packet_source.hpp"
#include "magnetometer_insitu_calibration/instrument/serial_port.hpp"

#include "test_support.hpp"
#include "test_constants.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <fcntl.h>
#include <fstream>
#include <numeric>
#include <stdlib.h>
#include <unistd.h>
#include <vector>

using namespace magnetometer_insitu_calibration;
using Bytes = std::vector<std::uint8_t>;
using Clock = std::chrono::steady_clock;

namespace {

using magnetometer_insitu_calibration::test::kT0;

// The master side of a pty; the slave name is what a driver would open.
class Pty {
 public:
  Pty() {
    master_ = posix_openpt(O_RDWR | O_NOCTTY);
    if (master_ < 0 || grantpt(master_) != 0 || unlockpt(master_) != 0)
      throw std::runtime_error("cannot create a pty");
    slave_ = ptsname(master_);
  }
  ~Pty() { close(); }
  void close() {
    if (master_ >= 0) ::close(master_);
    master_ = -1;
  }
  void write(const Bytes& bytes) const {
    std::size_t done = 0;
    while (done < bytes.size()) {
      const ssize_t n = ::write(master_, bytes.data() + done, bytes.size() - done);
      if (n <= 0) throw std::runtime_error("pty write failed");
      done += static_cast<std::size_t>(n);
    }
  }
  const std::string& slave() const { return slave_; }

 private:
  int master_ = -1;
  std::string slave_;
};

Bytes packet_bytes(int i) {
  Lemi025Packet p;
  p.gps_time_s = kT0 + i;
  p.station = 0x0D;  // CR: would become LF without raw mode
  p.dac_counts = {0x0A0D, 0x1311, 0x0304};  // LF CR, XON XOFF, ^D ^C
  p.bias_nT = Eigen::Vector3d(20000.0, 0.0, 44000.0);
  for (int k = 0; k < 10; ++k) p.variation_nT(k, 0) = 10.0 * i + k;
  p.mode = 2;
  p.gps_status = 'A';
  const auto a = encode_lemi025_packet(p, ChecksumMode::kSum8);
  return Bytes(a.begin(), a.end());
}

// Reads from `source` until `count` bytes arrived or 30 s passed (a hang, never a busy machine).
Bytes read_bytes(ByteSource& source, std::size_t count) {
  Bytes got;
  std::uint8_t buffer[512];
  const auto deadline = Clock::now() + std::chrono::seconds(30);
  while (got.size() < count && Clock::now() < deadline) {
    const std::size_t n = source.read(buffer, sizeof buffer, 0.2);
    got.insert(got.end(), buffer, buffer + n);
  }
  return got;
}

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

void point_link(const std::string& link, const std::string& target) {
  const std::string tmp = link + ".new";
  ::unlink(tmp.c_str());
  ASSERT_EQ(::symlink(target.c_str(), tmp.c_str()), 0);
  ASSERT_EQ(::rename(tmp.c_str(), link.c_str()), 0);  // atomic, like the simulator
}

}  // namespace

TEST(SerialPortSource, RawEightBitRoundTripOnPty) {
  Pty pty;
  SerialPortSource port(pty.slave(), 57600);
  ASSERT_TRUE(port.ok()) << port.last_error();
  EXPECT_EQ(port.describe(), "serial " + pty.slave() + " 57600 8N1");
  Bytes all(256);
  std::iota(all.begin(), all.end(), 0);  // every byte value, CR LF XON XOFF ^C ^D DEL included
  pty.write(all);
  pty.write(all);
  EXPECT_EQ(read_bytes(port, 512), [&] {
    Bytes twice = all;
    twice.insert(twice.end(), all.begin(), all.end());
    return twice;
  }());
}

TEST(SerialPortSource, TimeoutReturnsZeroAndStaysConnected) {
  Pty pty;
  SerialPortSource port(pty.slave(), 19200);
  std::uint8_t buffer[16];
  const auto start = Clock::now();
  EXPECT_EQ(port.read(buffer, sizeof buffer, 0.2), 0u);
  const double waited = seconds_since(start);
  EXPECT_GE(waited, 0.15);
  EXPECT_LT(waited, 10.0);  // returns, not blocks (the bound is for a hang, not a busy machine)
  EXPECT_TRUE(port.ok());
  EXPECT_EQ(port.read(buffer, sizeof buffer, 0.0), 0u);  // poll
  EXPECT_TRUE(port.ok());
}

TEST(SerialPortSource, DetectsDisconnectAndReopens) {
  const std::string dir = test::make_temp_dir("lemi_pty");
  const std::string link = dir + "/lemi_ref";
  auto first = std::make_unique<Pty>();
  point_link(link, first->slave());
  SerialPortSource port(link, 57600);
  ASSERT_TRUE(port.ok()) << port.last_error();
  first->write(packet_bytes(0));
  EXPECT_EQ(read_bytes(port, 153), packet_bytes(0));

  // The instrument side goes away, its link first (as udev and socat do): a link left pointing at
  // a freed pty number can name another process's new pty on a busy machine.
  ::unlink(link.c_str());
  first->close();
  std::uint8_t buffer[64];
  const auto start = Clock::now();
  while (port.ok() && seconds_since(start) < 30.0) port.read(buffer, sizeof buffer, 0.1);
  EXPECT_FALSE(port.ok());
  EXPECT_EQ(port.disconnects(), 1u);
  EXPECT_FALSE(port.last_error().empty());
  EXPECT_EQ(port.read(buffer, sizeof buffer, 0.1), 0u);
  first.reset();
  EXPECT_FALSE(port.reopen());  // no link: nothing to open

  Pty second;
  point_link(link, second.slave());
  ASSERT_TRUE(port.reopen()) << port.last_error();
  EXPECT_TRUE(port.ok());
  second.write(packet_bytes(1));
  EXPECT_EQ(read_bytes(port, 153), packet_bytes(1));
}

// The link is re-pointed to another pty while the first one stays open and silent (socat or the
// simulator re-created the pty; or the stale link of an unplugged pty whose number the kernel
// gave to someone else's pty, and the instrument's new pty then replaced it): the port follows
// the path. Before, it kept reading the old device forever: the new pty's bytes never came.
TEST(SerialPortSource, FollowsTheLinkToAnotherDevice) {
  const std::string link = test::make_temp_dir("lemi_repoint") + "/lemi_ref";
  Pty first;
  point_link(link, first.slave());
  SerialPortSource port(link, 57600);
  ASSERT_TRUE(port.ok()) << port.last_error();
  first.write(packet_bytes(0));
  EXPECT_EQ(read_bytes(port, 153), packet_bytes(0));

  Pty second;  // `first` stays open: a live device, no hang-up
  point_link(link, second.slave());
  std::uint8_t buffer[64];
  const auto start = Clock::now();
  while (port.ok() && seconds_since(start) < 30.0) port.read(buffer, sizeof buffer, 0.1);  // a hang fails this
  ASSERT_FALSE(port.ok()) << "still reading the device the link named before";
  EXPECT_NE(port.last_error().find("now names another device"), std::string::npos) << port.last_error();
  EXPECT_EQ(port.disconnects(), 1u);
  ASSERT_TRUE(port.reopen()) << port.last_error();
  second.write(packet_bytes(1));  // after the reopen: raw mode is set (a ^C byte would flush a cooked tty)
  EXPECT_EQ(read_bytes(port, 153), packet_bytes(1));
}

TEST(SerialPortSource, MissingDeviceBadBaudAndNonTty) {
  SerialPortSource missing("/nonexistent/ttyLEMI", 57600);
  EXPECT_FALSE(missing.ok());
  EXPECT_NE(missing.last_error().find("/nonexistent/ttyLEMI"), std::string::npos);
  EXPECT_FALSE(missing.reopen());
  std::uint8_t buffer[4];
  EXPECT_EQ(missing.read(buffer, 4, 0.0), 0u);
  EXPECT_THROW(SerialPortSource("/dev/null", 12345), InputError);
  EXPECT_TRUE(SerialPortSource::is_supported_baud(19200));
  EXPECT_FALSE(SerialPortSource::is_supported_baud(56000));
  SerialPortSource not_tty("/dev/null", 57600);
  EXPECT_FALSE(not_tty.ok());
  EXPECT_NE(not_tty.last_error().find("not a serial port"), std::string::npos);
}

TEST(StreamPacketSource, PacketsFromPtyThroughDisconnectAndReconnect) {
  const std::string dir = test::make_temp_dir("lemi_pty_packets");
  const std::string link = dir + "/lemi_test";
  auto first = std::make_unique<Pty>();
  point_link(link, first->slave());
  StreamPacketSourceOptions options;
  options.parser.checksum = ChecksumMode::kSum8;
  options.reopen_interval_s = 0.05;
  StreamPacketSource source(std::make_unique<SerialPortSource>(link, 57600), options);
  EXPECT_TRUE(source.connected());

  // Packet 0 whole, packet 1 in two writes, then half of packet 2 before the cable is pulled.
  first->write(packet_bytes(0));
  const Bytes p1 = packet_bytes(1);
  first->write(Bytes(p1.begin(), p1.begin() + 70));
  auto a = source.next(30.0);
  ASSERT_TRUE(a.has_value());
  EXPECT_EQ(a->gps_time_s, kT0);
  EXPECT_EQ(a->station, 0x0D);
  EXPECT_EQ(a->dac_counts[1], 0x1311);
  first->write(Bytes(p1.begin() + 70, p1.end()));
  auto b = source.next(30.0);
  ASSERT_TRUE(b.has_value());
  EXPECT_EQ(b->gps_time_s, kT0 + 1);
  EXPECT_NEAR(b->variation_nT(3, 0), 13.0, 1e-4);  // float32 uT
  const Bytes p2 = packet_bytes(2);
  first->write(Bytes(p2.begin(), p2.begin() + 80));
  EXPECT_FALSE(source.next(0.3).has_value());  // waits for the rest
  ::unlink(link.c_str());  // disconnect, the link first (a stale link could name another pty)
  first.reset();
  EXPECT_FALSE(source.next(0.3).has_value());
  EXPECT_FALSE(source.connected());
  EXPECT_FALSE(source.at_end());
  EXPECT_EQ(source.stats().disconnects, 1u);

  Pty second;
  point_link(link, second.slave());
  std::optional<Lemi025Packet> c;
  const auto start = Clock::now();
  bool written = false;
  while (!c && seconds_since(start) < 30.0) {
    c = source.next(0.1);
    if (source.connected() && !written) {
      second.write(packet_bytes(5));
      written = true;
    }
  }
  ASSERT_TRUE(c.has_value());
  EXPECT_EQ(c->gps_time_s, kT0 + 5);
  const PacketSourceStats s = source.stats();
  EXPECT_EQ(s.reconnects, 1u);
  EXPECT_EQ(s.parser.packets, 3u);
  EXPECT_EQ(s.parser.bytes_skipped, 80u);  // the half packet cut by the disconnection
  EXPECT_EQ(s.parser.time_jumps, 0u);      // a new sequence after the reconnection
  const auto warnings = source.take_warnings();
  ASSERT_GE(warnings.size(), 2u);
  EXPECT_EQ(warnings[0].rfind("disconnected: serial " + link + " 57600 8N1 (", 0), 0u) << warnings[0];  // and why
  EXPECT_EQ(warnings[1], "reconnected: serial " + link + " 57600 8N1");
}

namespace {

std::string write_stream_file(const std::string& name, int packets) {
  const std::string path = test::make_temp_dir("lemi_file_source") + "/" + name;
  std::ofstream out(path, std::ios::binary);
  for (int i = 0; i < packets; ++i) {
    const Bytes b = packet_bytes(i);
    out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
  }
  return path;
}

}  // namespace

TEST(FileByteSource, ReadsToEndRewindsAndLoops) {
  const std::string path = write_stream_file("two.raw", 2);
  FileByteSourceOptions options;
  options.max_chunk = 100;
  FileByteSource source(path, options);
  std::uint8_t buffer[512];
  EXPECT_EQ(source.read(buffer, sizeof buffer, 0.0), 100u);
  Bytes rest = read_bytes(source, 206);
  EXPECT_EQ(rest.size(), 206u);
  EXPECT_TRUE(source.finished());
  EXPECT_FALSE(source.ok());
  EXPECT_EQ(source.read(buffer, sizeof buffer, 0.0), 0u);
  EXPECT_TRUE(source.reopen());
  EXPECT_EQ(source.read(buffer, 153, 0.0), 100u);
  EXPECT_EQ(buffer[0], 'L');

  options.loop = true;
  FileByteSource looped(path, options);
  const Bytes three_passes = read_bytes(looped, 3 * 306);
  ASSERT_EQ(three_passes.size(), 3u * 306);
  EXPECT_EQ(Bytes(three_passes.begin() + 612, three_passes.begin() + 612 + 153), packet_bytes(0));
  EXPECT_FALSE(looped.finished());
  EXPECT_THROW(FileByteSource("/nonexistent/capture.raw"), InputError);
}

TEST(FileByteSource, PacingFollowsTheByteRate) {
  const std::string path = write_stream_file("paced.raw", 2);
  FileByteSourceOptions options;
  options.bytes_per_second = 1530.0;  // 306 bytes in 0.2 s
  FileByteSource source(path, options);
  const auto start = Clock::now();
  const Bytes all = read_bytes(source, 306);
  const double took = seconds_since(start);
  EXPECT_EQ(all.size(), 306u);
  EXPECT_GE(took, 0.17);
  EXPECT_LT(took, 10.0);  // paced, not stuck (the bound is for a hang, not a busy machine)
  std::uint8_t buffer[8];
  EXPECT_EQ(source.read(buffer, sizeof buffer, 0.0), 0u);
  EXPECT_TRUE(source.finished());
}

TEST(StreamPacketSource, RecordedStreamInSmallChunksToTheEnd) {
  const std::string path = write_stream_file("five.raw", 5);
  FileByteSourceOptions file_options;
  file_options.max_chunk = 7;
  StreamPacketSource source(std::make_unique<FileByteSource>(path, file_options), ChecksumMode::kSum8);
  std::vector<double> t;
  while (auto p = source.next(1.0)) t.push_back(p->gps_time_s - kT0);
  EXPECT_EQ(t, (std::vector<double>{0, 1, 2, 3, 4}));
  EXPECT_TRUE(source.at_end());
  EXPECT_EQ(source.stats().parser.packets, 5u);
  EXPECT_EQ(source.stats().parser.bytes_skipped, 0u);
  EXPECT_EQ(source.stats().disconnects, 0u);
  EXPECT_NE(source.describe().find("sum8"), std::string::npos);
  EXPECT_THROW(StreamPacketSource(nullptr), InputError);
}

TEST(StreamPacketSource, DeviceAbsentAtStartIsRetriedNotCountedAsLoss) {
  const std::string link = test::make_temp_dir("lemi_late") + "/lemi_late";
  StreamPacketSourceOptions options;
  options.reopen_interval_s = 0.05;
  StreamPacketSource source(std::make_unique<SerialPortSource>(link, 57600), options);
  EXPECT_FALSE(source.connected());
  EXPECT_FALSE(source.next(0.2).has_value());
  EXPECT_FALSE(source.at_end());
  Pty pty;  // the adapter is plugged in
  point_link(link, pty.slave());
  std::optional<Lemi025Packet> p;
  const auto start = Clock::now();
  bool written = false;
  while (!p && seconds_since(start) < 30.0) {
    p = source.next(0.1);
    if (source.connected() && !written) {
      pty.write(packet_bytes(3));
      written = true;
    }
  }
  ASSERT_TRUE(p.has_value());
  EXPECT_EQ(p->gps_time_s, kT0 + 3);
  EXPECT_EQ(source.stats().disconnects, 0u);
  EXPECT_EQ(source.stats().reconnects, 1u);
  const auto warnings = source.take_warnings();
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_EQ(warnings[0], "not connected: serial " + link + " 57600 8N1");
}
