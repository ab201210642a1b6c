// Fixtures of the archived-record tests (test_archive_records, test_export_corrected,
// test/ros/test_bag_records): a simulated 10 Hz record written in the three LEMI formats with
// known temperatures, and text-file surgery for damaged lines.
#pragma once

#include "magnetometer_insitu_calibration/formats/lemi025_packet.hpp"
#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"
#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <cmath>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration::test {

/// A LEMI-025 bias that is a whole number of 2.5 nT steps.
inline Eigen::Vector3d lemi_bias_nT() { return Eigen::Vector3d(20000.0, 500.0, 42500.0); }

/// Known temperatures of packet j (deg C, two decimals as the packet stores them).
inline double lemi_sensor_temperature(std::size_t j) { return 21.0 + 0.01 * static_cast<double>(j % 300); }
inline double lemi_electronics_temperature(std::size_t j) { return 30.5 - 0.01 * static_cast<double>(j % 200); }

/// Packets of a 10 Hz record whose sample i is at t0 - 0.3 + 0.1 i with t0 a whole second
/// (simulate_pair with start_time_s = t0 - 0.3 and sample_period_s = 0.1): packet j has GPS
/// second t0 + j and readings 10 j .. 10 j + 9 as variations relative to lemi_bias_nT().
inline std::vector<Lemi025Packet> lemi_packets_of(const VectorRecord& record, double t0) {
  const std::size_t packets = record.size() / kLemi025ReadingsPerPacket;
  std::vector<Lemi025Packet> out(packets);
  for (std::size_t j = 0; j < packets; ++j) {
    Lemi025Packet& p = out[j];
    p.gps_time_s = t0 + static_cast<double>(j);
    p.station = 7;
    p.bias_nT = lemi_bias_nT();
    p.sensor_temperature_C = lemi_sensor_temperature(j);
    p.electronics_temperature_C = lemi_electronics_temperature(j);
    p.supply_V = 12.3;
    p.gps_status = 'A';
    p.mode = 2;
    p.flash_free_percent = 90;
    for (int k = 0; k < kLemi025ReadingsPerPacket; ++k) {
      const auto row = static_cast<Eigen::Index>(j * kLemi025ReadingsPerPacket + static_cast<std::size_t>(k));
      p.variation_nT.row(k) = record.values_nT.row(row) - lemi_bias_nT().transpose();
    }
  }
  return out;
}

inline void write_bytes(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!out) throw std::runtime_error("cannot write " + path);
}

/// Raw serial capture of the packets; `garbage_after` (packet indices) get 37 bytes of noise
/// after them, which the reader must skip and report.
inline void write_lemi_stream(const std::string& path, const std::vector<Lemi025Packet>& packets,
                              const std::vector<std::size_t>& garbage_after = {}) {
  std::vector<std::uint8_t> bytes;
  for (std::size_t j = 0; j < packets.size(); ++j) {
    const auto encoded = encode_lemi025_packet(packets[j], ChecksumMode::kNone);
    bytes.insert(bytes.end(), encoded.begin(), encoded.end());
    for (std::size_t g : garbage_after) {
      if (g != j) continue;
      for (int b = 0; b < 37; ++b) bytes.push_back(static_cast<std::uint8_t>(0x5A ^ (b * 29)));
    }
  }
  write_bytes(path, bytes);
}

/// LemiBin file (header line + 169-byte records, PC time = GPS time + 0.5 s).
inline void write_lemi_bin_file(const std::string& path, const std::vector<Lemi025Packet>& packets) {
  std::vector<LemiBinRecord> records(packets.size());
  for (std::size_t j = 0; j < packets.size(); ++j) {
    records[j].packet = packets[j];
    records[j].pc_time_s = packets[j].gps_time_s + 0.5;
  }
  write_lemi_bin(path, records, "LEMI025_TEST");
}

/// Compact-flash image: 3 packets per 512-byte block, preceded by one erased block.
inline void write_lemi_flash(const std::string& path, const std::vector<Lemi025Packet>& packets) {
  std::vector<std::uint8_t> bytes(kLemiFlashBlockSize, 0xFF);
  for (std::size_t j = 0; j + 3 <= packets.size(); j += 3) {
    LemiFlashBlock b;
    b.station = 7;
    b.time_s = packets[j].gps_time_s;
    b.latitude_deg = 47.928;
    b.longitude_deg = 15.861;
    b.gps_status = 'A';
    b.supply_V = 12.3;
    b.bias_nT = lemi_bias_nT();
    for (int s = 0; s < 3; ++s) {
      for (int k = 0; k < kLemi025ReadingsPerPacket; ++k) {
        const int r = kLemi025ReadingsPerPacket * s + k;
        b.variation_nT.row(r) = packets[j + static_cast<std::size_t>(s)].variation_nT.row(k);
        b.sensor_temperature_C[r] = packets[j + static_cast<std::size_t>(s)].sensor_temperature_C;
        b.electronics_temperature_C[r] = packets[j + static_cast<std::size_t>(s)].electronics_temperature_C;
      }
    }
    const auto encoded = encode_lemi_flash_block(b);
    bytes.insert(bytes.end(), encoded.begin(), encoded.end());
  }
  write_bytes(path, bytes);
}

/// Lines of a text file (without line ends; "\r" of CRLF removed) and back (CRLF or LF).
inline std::vector<std::string> read_lines(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<std::string> lines;
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(line);
  }
  return lines;
}

inline void write_lines(const std::string& path, const std::vector<std::string>& lines, bool crlf) {
  std::ofstream out(path, std::ios::binary);
  for (const std::string& l : lines) out << l << (crlf ? "\r\n" : "\n");
}

/// Index (0-based) of the first IAGA-2002 data line (after "DATE TIME DOY ...").
inline std::size_t iaga_first_data_line(const std::vector<std::string>& lines) {
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].compare(0, 4, "DATE") == 0) return i + 1;
  }
  throw std::runtime_error("no IAGA-2002 column header");
}

/// The record without the samples at `drop` (sorted indices).
inline VectorRecord without_samples(const VectorRecord& record, const std::vector<std::size_t>& drop) {
  VectorRecord out = record;
  out.time_s.clear();
  std::vector<Eigen::Index> keep;
  std::size_t d = 0;
  for (std::size_t i = 0; i < record.size(); ++i) {
    if (d < drop.size() && drop[d] == i) {
      ++d;
      continue;
    }
    out.time_s.push_back(record.time_s[i]);
    keep.push_back(static_cast<Eigen::Index>(i));
  }
  out.values_nT.resize(static_cast<Eigen::Index>(keep.size()), 3);
  for (std::size_t k = 0; k < keep.size(); ++k) out.values_nT.row(static_cast<Eigen::Index>(k)) = record.values_nT.row(keep[k]);
  return out;
}

/// True when both have the same times and bit-identical values (NaN equal to NaN).
inline bool same_samples(const VectorRecord& a, const VectorRecord& b, std::string* why = nullptr) {
  auto fail = [&](const std::string& text) {
    if (why != nullptr) *why = text;
    return false;
  };
  if (a.size() != b.size()) return fail("sizes " + std::to_string(a.size()) + " and " + std::to_string(b.size()));
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a.time_s[i] != b.time_s[i]) return fail("time of sample " + std::to_string(i));
    for (int c = 0; c < 3; ++c) {
      const double x = a.values_nT(static_cast<Eigen::Index>(i), c), y = b.values_nT(static_cast<Eigen::Index>(i), c);
      if (!(x == y || (std::isnan(x) && std::isnan(y)))) {
        std::ostringstream text;
        text.precision(17);
        text << "sample " << i << " component " << c << ": " << x << " vs " << y;
        return fail(text.str());
      }
    }
  }
  return true;
}

}  // namespace magnetometer_insitu_calibration::test
