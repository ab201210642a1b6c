// Byte-building helpers shared by the LEMI archive tests (test_lemi_archive.cpp,
// test_lemi_compact_flash.cpp): files are written byte by byte, independently of the library.
#pragma once

#include "test_support.hpp"

#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

namespace lemi_test {

using Bytes = std::vector<std::uint8_t>;

// 2024-03-05 12:34:50 UTC (python: calendar.timegm((2024,3,5,12,34,50))).
constexpr double kArchiveT0 = 1709642090.0;

inline void put_i16(Bytes& b, std::size_t at, int value) {
  const auto u = static_cast<std::uint16_t>(static_cast<std::int16_t>(value));
  b[at] = static_cast<std::uint8_t>(u & 0xFF);
  b[at + 1] = static_cast<std::uint8_t>(u >> 8);
}

inline void put_u32(Bytes& b, std::size_t at, std::uint32_t value) {
  for (int i = 0; i < 4; ++i) b[at + i] = static_cast<std::uint8_t>(value >> (8 * i));
}

inline void put_f32(Bytes& b, std::size_t at, float value) {
  std::uint32_t bits;
  std::memcpy(&bits, &value, 4);
  put_u32(b, at, bits);
}

inline void append(Bytes& to, const Bytes& from) { to.insert(to.end(), from.begin(), from.end()); }

/// Writes `bytes` to a file `name` in this test's temporary directory; returns its path.
inline std::string write_file(const std::string& name, const Bytes& bytes) {
  static const std::string dir = magnetometer_insitu_calibration::test::make_temp_dir("lemi_archive");
  const std::string path = dir + "/" + name;
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  return path;
}

/// Whether any of `lines` contains `text`.
inline bool contains(const std::vector<std::string>& lines, const std::string& text) {
  for (const auto& l : lines)
    if (l.find(text) != std::string::npos) return true;
  return false;
}

}  // namespace lemi_test
