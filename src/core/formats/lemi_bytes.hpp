// Private to the LEMI sources: little-endian field access independent of the host byte order.
#pragma once

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>

namespace magnetometer_insitu_calibration::lemi_detail {

inline std::int16_t read_i16(const std::uint8_t* p) {
  return static_cast<std::int16_t>(static_cast<std::uint16_t>(p[0] | (p[1] << 8)));
}

inline std::uint32_t read_u32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}

inline float read_f32(const std::uint8_t* p) {
  const std::uint32_t bits = read_u32(p);
  float value;
  std::memcpy(&value, &bits, sizeof value);
  return value;
}

inline void write_i16(std::uint8_t* p, std::int16_t value) {
  const auto u = static_cast<std::uint16_t>(value);
  p[0] = static_cast<std::uint8_t>(u & 0xFF);
  p[1] = static_cast<std::uint8_t>(u >> 8);
}

inline void write_u32(std::uint8_t* p, std::uint32_t value) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(value >> (8 * i));
}

inline void write_f32(std::uint8_t* p, float value) {
  std::uint32_t bits;
  std::memcpy(&bits, &value, sizeof bits);
  write_u32(p, bits);
}

/// `value` rounded to an int16 field, or InputError(source, "<what> does not fit its int16 field").
inline std::int16_t checked_int16(double value, const char* source, const char* what) {
  const double rounded = std::round(value);
  if (!(rounded >= -32768.0 && rounded <= 32767.0))
    throw InputError(source, std::string(what) + " does not fit its int16 field");
  return static_cast<std::int16_t>(rounded);
}

/// True if p[0..3] is "L025" or "L036".
inline bool is_lemi_tag(const std::uint8_t* p) {
  return p[0] == 'L' && p[1] == '0' &&
         ((p[2] == '2' && p[3] == '5') || (p[2] == '3' && p[3] == '6'));
}

}  // namespace magnetometer_insitu_calibration::lemi_detail
