// Lemi025StreamParser: split chunks, garbage, dropped and corrupted bytes, with exact counters.
// Packets are made by encode_lemi025_packet, itself checked byte by byte against a hand-built
// packet in test_lemi025_packet.cpp.
#include "magnetometer_insitu_calibration/formats/lemi025_stream_parser.hpp"
#include "test_constants.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <random>
#include <vector>

using namespace magnetometer_insitu_calibration;

namespace {

using magnetometer_insitu_calibration::test::kT0;
constexpr int kPackets = 8;

Lemi025Packet make_packet(int i) {
  Lemi025Packet p;
  p.station = 3;
  p.gps_time_s = kT0 + i;
  p.sensor_temperature_C = 21.5;
  p.electronics_temperature_C = -3.25;
  p.bias_nT = Eigen::Vector3d(20000.0, 1500.0, 44000.0);
  for (int k = 0; k < 10; ++k) {
    p.variation_nT(k, 0) = 100.0 * i + k;  // exact in float32 uT? no: compared with tolerance
    p.variation_nT(k, 1) = -50.0 * i - k;
    p.variation_nT(k, 2) = 7.0 * k;
  }
  p.mode = 2;
  p.flash_free_percent = 50;
  p.supply_V = 12.0;
  p.gps_status = 'A';
  return p;
}

using Bytes = std::vector<std::uint8_t>;

Bytes packet_bytes(int i, ChecksumMode mode) {
  const auto a = encode_lemi025_packet(make_packet(i), mode);
  return Bytes(a.begin(), a.end());
}

Bytes stream(int count, ChecksumMode mode) {
  Bytes all;
  for (int i = 0; i < count; ++i) {
    const Bytes b = packet_bytes(i, mode);
    all.insert(all.end(), b.begin(), b.end());
  }
  return all;
}

std::vector<Lemi025Packet> feed_in_chunks(Lemi025StreamParser& parser, const Bytes& bytes,
                                          std::size_t chunk) {
  std::vector<Lemi025Packet> out;
  for (std::size_t at = 0; at < bytes.size(); at += chunk) {
    const std::size_t n = std::min(chunk, bytes.size() - at);
    for (auto& p : parser.feed(bytes.data() + at, n)) out.push_back(p);
  }
  return out;
}

std::vector<double> times(const std::vector<Lemi025Packet>& packets) {
  std::vector<double> t;
  for (const auto& p : packets) t.push_back(p.gps_time_s - kT0);
  return t;
}

}  // namespace

TEST(Lemi025StreamParser, CleanStreamWholeAndInEveryChunkSize) {
  const Bytes bytes = stream(kPackets, ChecksumMode::kNone);
  for (std::size_t chunk : {std::size_t{1}, std::size_t{2}, std::size_t{3}, std::size_t{7},
                            std::size_t{152}, std::size_t{153}, std::size_t{154},
                            std::size_t{500}, bytes.size()}) {
    Lemi025StreamParser parser;
    const auto packets = feed_in_chunks(parser, bytes, chunk);
    ASSERT_EQ(packets.size(), static_cast<std::size_t>(kPackets)) << "chunk " << chunk;
    for (int i = 0; i < kPackets; ++i) {
      EXPECT_EQ(packets[i].gps_time_s, kT0 + i);
      EXPECT_NEAR(packets[i].variation_nT(9, 0), 100.0 * i + 9, 1e-3);
      EXPECT_NEAR(packets[i].variation_nT(4, 1), -50.0 * i - 4, 1e-3);
      EXPECT_DOUBLE_EQ(packets[i].bias_nT[2], 44000.0);
    }
    const Lemi025ParserStats& s = parser.stats();
    EXPECT_EQ(s.packets, static_cast<std::uint64_t>(kPackets));
    EXPECT_EQ(s.checksum_errors, 0u);
    EXPECT_EQ(s.resyncs, 0u);
    EXPECT_EQ(s.bytes_skipped, 0u);
    EXPECT_EQ(s.time_jumps, 0u);
    EXPECT_EQ(s.bytes_fed, bytes.size());
    EXPECT_EQ(parser.buffered(), 0u);
  }
}

TEST(Lemi025StreamParser, PacketSplitAcrossChunksWaits) {
  const Bytes bytes = packet_bytes(0, ChecksumMode::kNone);
  Lemi025StreamParser parser;
  EXPECT_TRUE(parser.feed(bytes.data(), 100).empty());
  EXPECT_EQ(parser.buffered(), 100u);
  EXPECT_EQ(parser.stats().bytes_skipped, 0u);
  const auto packets = parser.feed(bytes.data() + 100, 53);
  ASSERT_EQ(packets.size(), 1u);
  EXPECT_EQ(packets[0].gps_time_s, kT0);
}

TEST(Lemi025StreamParser, GarbageBeforeAndBetweenPackets) {
  Bytes bytes = {0x00, 0x13, 'L', '0', '2', 0x99, 0xFF};  // 7 bytes, with a broken tag
  const std::size_t lead = bytes.size();
  const Bytes clean = stream(kPackets, ChecksumMode::kNone);
  bytes.insert(bytes.end(), clean.begin(), clean.begin() + 3 * 153);
  // 40 bytes of garbage holding a complete fake tag followed by non-BCD bytes.
  Bytes garbage(40, 0xAB);
  garbage[5] = 'L'; garbage[6] = '0'; garbage[7] = '2'; garbage[8] = '5';
  bytes.insert(bytes.end(), garbage.begin(), garbage.end());
  bytes.insert(bytes.end(), clean.begin() + 3 * 153, clean.end());

  Lemi025StreamParser parser;
  const auto found = parser.feed_with_offsets(bytes.data(), bytes.size());
  ASSERT_EQ(found.size(), static_cast<std::size_t>(kPackets));
  EXPECT_EQ(found[0].offset, lead);
  EXPECT_EQ(found[3].offset, lead + 3 * 153 + 40);
  const Lemi025ParserStats& s = parser.stats();
  EXPECT_EQ(s.bytes_skipped, lead + 40);
  EXPECT_EQ(s.resyncs, 2u);
  EXPECT_EQ(s.time_jumps, 0u);
  const auto warnings = parser.take_warnings();
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_EQ(warnings[0], "stream byte 0: skipped 7 bytes (no packet tag)");
  EXPECT_NE(warnings[1].find("stream byte " + std::to_string(lead + 3 * 153) + ": skipped 40"),
            std::string::npos)
      << warnings[1];
  EXPECT_TRUE(parser.take_warnings().empty());
}

TEST(Lemi025StreamParser, DroppedBytesInsideReadingsLoseOnlyThatPacket) {
  // No checksum: the moved tail (mode/flash/GPS-status bytes) is what exposes the short packet.
  Bytes bytes = stream(kPackets, ChecksumMode::kNone);
  const std::size_t p3 = 3 * 153;
  bytes.erase(bytes.begin() + p3 + 60, bytes.begin() + p3 + 70);  // 10 bytes lost
  for (std::size_t chunk : {std::size_t{1}, std::size_t{64}, bytes.size()}) {
    Lemi025StreamParser parser;
    const auto packets = feed_in_chunks(parser, bytes, chunk);
    EXPECT_EQ(times(packets), (std::vector<double>{0, 1, 2, 4, 5, 6, 7})) << "chunk " << chunk;
    const Lemi025ParserStats& s = parser.stats();
    EXPECT_EQ(s.packets, 7u);
    EXPECT_EQ(s.bytes_skipped, 143u);  // what is left of packet 3
    EXPECT_EQ(s.resyncs, 1u);
    EXPECT_EQ(s.time_jumps, 1u);       // 2 -> 4
    EXPECT_EQ(s.checksum_errors, 0u);
  }
}

TEST(Lemi025StreamParser, DroppedTagByte) {
  Bytes bytes = stream(kPackets, ChecksumMode::kNone);
  bytes.erase(bytes.begin() + 5 * 153 + 2);  // "L05..." is no tag any more
  Lemi025StreamParser parser;
  const auto packets = parser.feed(bytes);
  EXPECT_EQ(times(packets), (std::vector<double>{0, 1, 2, 3, 4, 6, 7}));
  EXPECT_EQ(parser.stats().bytes_skipped, 152u);
  EXPECT_EQ(parser.stats().resyncs, 1u);
  EXPECT_EQ(parser.stats().time_jumps, 1u);
}

TEST(Lemi025StreamParser, CorruptedReadingByteWithChecksum) {
  for (ChecksumMode mode : {ChecksumMode::kSum8, ChecksumMode::kXor8}) {
    Bytes bytes = stream(kPackets, mode);
    bytes[2 * 153 + 77] ^= 0x10;
    Lemi025StreamParser parser(mode);
    const auto packets = feed_in_chunks(parser, bytes, 50);
    EXPECT_EQ(times(packets), (std::vector<double>{0, 1, 3, 4, 5, 6, 7}));
    const Lemi025ParserStats& s = parser.stats();
    EXPECT_EQ(s.checksum_errors, 1u);
    EXPECT_EQ(s.bytes_skipped, 0u);
    EXPECT_EQ(s.resyncs, 0u);
    EXPECT_EQ(s.time_jumps, 1u);
    const auto warnings = parser.take_warnings();
    ASSERT_GE(warnings.size(), 1u);
    EXPECT_EQ(warnings[0], "stream byte 306: packet dropped, " + checksum_mode_name(mode) +
                               " checksum mismatch");
  }
}

TEST(Lemi025StreamParser, WrongChecksumModeDropsEveryPacket) {
  const Bytes bytes = stream(kPackets, ChecksumMode::kSum8);
  Lemi025StreamParser parser(ChecksumMode::kXor8);
  EXPECT_TRUE(parser.feed(bytes).empty());
  EXPECT_EQ(parser.stats().checksum_errors, static_cast<std::uint64_t>(kPackets));
}

TEST(Lemi025StreamParser, CorruptedBytesWithoutChecksum) {
  {  // A corrupted tag byte loses that packet only.
    Bytes bytes = stream(kPackets, ChecksumMode::kNone);
    bytes[4 * 153] = 'M';
    Lemi025StreamParser parser;
    const auto packets = parser.feed(bytes);
    EXPECT_EQ(times(packets), (std::vector<double>{0, 1, 2, 3, 5, 6, 7}));
    EXPECT_EQ(parser.stats().bytes_skipped, 153u);
    EXPECT_EQ(parser.stats().resyncs, 1u);
  }
  {  // A corrupted GPS-status byte too.
    Bytes bytes = stream(kPackets, ChecksumMode::kNone);
    bytes[4 * 153 + 151] = 'Z';
    Lemi025StreamParser parser;
    EXPECT_EQ(times(parser.feed(bytes)), (std::vector<double>{0, 1, 2, 3, 5, 6, 7}));
    EXPECT_EQ(parser.stats().bytes_skipped, 153u);
  }
  {  // A seconds byte still valid BCD: accepted, seen as a jump there and back.
    Bytes bytes = stream(kPackets, ChecksumMode::kNone);
    bytes[4 * 153 + 10] = 0x59;  // 12:34:56+4 = :00 -> :59
    Lemi025StreamParser parser;
    const auto packets = parser.feed(bytes);
    EXPECT_EQ(packets.size(), static_cast<std::size_t>(kPackets));
    EXPECT_EQ(parser.stats().time_jumps, 2u);
    EXPECT_EQ(parser.stats().bytes_skipped, 0u);
  }
}

TEST(Lemi025StreamParser, RealTimeJumpIsAcceptedAndCounted) {
  Bytes bytes;
  for (int i : {0, 1, 2, 10, 11, 5}) {
    const Bytes b = packet_bytes(i, ChecksumMode::kNone);
    bytes.insert(bytes.end(), b.begin(), b.end());
  }
  Lemi025StreamParser parser;
  EXPECT_EQ(times(parser.feed(bytes)), (std::vector<double>{0, 1, 2, 10, 11, 5}));
  EXPECT_EQ(parser.stats().time_jumps, 2u);
  EXPECT_EQ(parser.stats().resyncs, 0u);
}

TEST(Lemi025StreamParser, FlushCountsPartialPacketAndRestartsSequence) {
  const Bytes bytes = stream(3, ChecksumMode::kNone);
  Lemi025StreamParser parser;
  EXPECT_EQ(parser.feed(bytes.data(), 2 * 153 + 20).size(), 2u);
  parser.flush();
  EXPECT_EQ(parser.stats().bytes_skipped, 20u);
  EXPECT_EQ(parser.stats().resyncs, 1u);
  EXPECT_EQ(parser.buffered(), 0u);
  const auto warnings = parser.take_warnings();
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], "stream byte 306: skipped 20 bytes (incomplete packet at end of stream)");
  // After the interruption a packet 5 s later is not a time jump (new sequence).
  const Bytes later = packet_bytes(7, ChecksumMode::kNone);
  const auto found = parser.feed_with_offsets(later.data(), later.size());
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].offset, 2u * 153 + 20);
  EXPECT_EQ(parser.stats().time_jumps, 0u);
}

TEST(Lemi025StreamParser, LongRandomGarbageWithFakeTags) {
  std::mt19937 rng(12345);
  Bytes garbage(20000);
  for (auto& b : garbage) b = static_cast<std::uint8_t>(rng() & 0xFF);
  for (std::size_t at = 100; at + 4 < garbage.size(); at += 997) {  // plant fake tags
    garbage[at] = 'L'; garbage[at + 1] = '0'; garbage[at + 2] = '2'; garbage[at + 3] = '5';
  }
  Bytes bytes = garbage;
  const Bytes clean = stream(kPackets, ChecksumMode::kNone);
  bytes.insert(bytes.end(), clean.begin(), clean.end());
  Lemi025StreamParser parser;
  const auto packets = feed_in_chunks(parser, bytes, 333);
  EXPECT_EQ(times(packets), (std::vector<double>{0, 1, 2, 3, 4, 5, 6, 7}));
  EXPECT_EQ(parser.stats().bytes_skipped, garbage.size());
  EXPECT_EQ(parser.stats().resyncs, 1u);
}

TEST(Lemi025StreamParser, Lemi036PacketsInStream) {
  Lemi025Packet p = make_packet(0);
  p.model = LemiModel::kLemi036;
  const auto a = encode_lemi025_packet(p, ChecksumMode::kNone);
  Lemi025StreamParser parser;
  const auto packets = parser.feed(a.data(), a.size());
  ASSERT_EQ(packets.size(), 1u);
  EXPECT_EQ(packets[0].model, LemiModel::kLemi036);
}

// Bug A: a framed packet with implausible readings (failing ADC: 1e6 nT, NaN) is returned with
// NaN for those readings only and counted; before, it was skipped byte by byte as garbage and
// all 10 readings lost. Same with checksum none (status bytes frame the packet).
TEST(Lemi025StreamParser, ImplausibleReadingsBecomeNaNAndPacketIsKept) {
  for (ChecksumMode mode : {ChecksumMode::kSum8, ChecksumMode::kXor8, ChecksumMode::kNone}) {
    Bytes bytes;
    for (int i = 0; i < kPackets; ++i) {
      Lemi025Packet p = make_packet(i);
      if (i == 3) {
        p.variation_nT(2, 0) = 1.0e6;                                      // absurd magnitude
        p.variation_nT(5, 2) = -2.5e5;
        p.variation_nT(8, 1) = std::numeric_limits<double>::quiet_NaN();  // not finite
      }
      const auto a = encode_lemi025_packet(p, mode);
      bytes.insert(bytes.end(), a.begin(), a.end());
    }
    for (std::size_t chunk : {std::size_t{1}, std::size_t{77}, bytes.size()}) {
      Lemi025StreamParser parser(mode);
      const auto packets = feed_in_chunks(parser, bytes, chunk);
      ASSERT_EQ(times(packets), (std::vector<double>{0, 1, 2, 3, 4, 5, 6, 7}))
          << checksum_mode_name(mode) << " chunk " << chunk;
      const Lemi025Packet& bad = packets[3];
      for (int k = 0; k < 10; ++k) {
        if (k == 2 || k == 5 || k == 8) {
          EXPECT_TRUE(bad.variation_nT.row(k).array().isNaN().all()) << "reading " << k;
        } else {
          EXPECT_NEAR(bad.variation_nT(k, 0), 300.0 + k, 1e-3) << "reading " << k;
          EXPECT_NEAR(bad.variation_nT(k, 1), -150.0 - k, 1e-3) << "reading " << k;
          EXPECT_NEAR(bad.variation_nT(k, 2), 7.0 * k, 1e-3) << "reading " << k;
        }
      }
      EXPECT_TRUE(packets[2].variation_nT.allFinite());
      const Lemi025ParserStats& s = parser.stats();
      EXPECT_EQ(s.packets, 8u);
      EXPECT_EQ(s.implausible_readings, 3u);
      EXPECT_EQ(s.resyncs, 0u);
      EXPECT_EQ(s.bytes_skipped, 0u);
      EXPECT_EQ(s.checksum_errors, 0u);
      const auto warnings = parser.take_warnings();
      ASSERT_EQ(warnings.size(), 1u);
      EXPECT_EQ(warnings[0], "stream byte 459: 3 implausible readings set to NaN");
    }
  }
}

// Readings do not decide the frame, but header, time and tail still do: a packet whose BCD time
// is garbage, or one shortened by 8 bytes (a multiple of 4: its floats stay plausible), is still
// rejected by resynchronisation; the neighbours are kept. With checksum none and no status-byte
// check, implausible readings still reject the packet (nothing else frames it).
TEST(Lemi025StreamParser, GarbageHeaderStillRejectedWhenReadingsAreNot) {
  {
    Bytes bytes = stream(kPackets, ChecksumMode::kSum8);
    bytes[2 * 153 + 9] = 0xC7;  // minute byte not BCD
    Lemi025StreamParser parser(ChecksumMode::kSum8);
    EXPECT_EQ(times(parser.feed(bytes)), (std::vector<double>{0, 1, 3, 4, 5, 6, 7}));
    EXPECT_EQ(parser.stats().bytes_skipped, 153u);
    EXPECT_EQ(parser.stats().resyncs, 1u);
    EXPECT_EQ(parser.stats().implausible_readings, 0u);
  }
  {
    Bytes bytes = stream(kPackets, ChecksumMode::kNone);
    bytes.erase(bytes.begin() + 5 * 153 + 40, bytes.begin() + 5 * 153 + 48);
    Lemi025StreamParser parser;
    EXPECT_EQ(times(parser.feed(bytes)), (std::vector<double>{0, 1, 2, 3, 4, 6, 7}));
    EXPECT_EQ(parser.stats().bytes_skipped, 145u);
    EXPECT_EQ(parser.stats().resyncs, 1u);
  }
  {
    Lemi025ParserOptions options;
    options.plausibility.check_status_bytes = false;
    Bytes bytes;
    for (int i = 0; i < 3; ++i) {
      Lemi025Packet p = make_packet(i);
      if (i == 1) p.variation_nT(0, 0) = 1.0e6;
      const auto a = encode_lemi025_packet(p, ChecksumMode::kNone);
      bytes.insert(bytes.end(), a.begin(), a.end());
    }
    Lemi025StreamParser parser(options);
    EXPECT_EQ(times(parser.feed(bytes)), (std::vector<double>{0, 2}));
    EXPECT_EQ(parser.stats().bytes_skipped, 153u);
    EXPECT_EQ(parser.stats().implausible_readings, 0u);
  }
}
