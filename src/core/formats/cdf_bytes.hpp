// Private to the CDF sources: bounds-checked big-endian access to the internal records, and
// decoding of values in the file's encoding.
#pragma once

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration::cdf_detail {

/// Largest uncompressed file, and largest array of one variable's values, read: 256 MiB (a day
/// of 10 Hz three-component doubles is 21 MB).
constexpr std::size_t kMaxBytes = std::size_t{1} << 28;

// CDF internal record types.
constexpr std::int32_t kCdr = 1, kGdr = 2, kRvdr = 3, kAdr = 4, kAgredr = 5, kVxr = 6, kVvr = 7, kZvdr = 8,
                       kAzedr = 9, kCcr = 10, kCpr = 11, kCvvr = 13;
constexpr std::int32_t kGzip = 5;  // compression type

inline std::string at_byte(std::uint64_t offset) { return " at byte " + std::to_string(offset); }

/// A reading position in the uncompressed file. Offsets are 8 bytes (CDF 3) or 4 (CDF 2).
class Cursor {
 public:
  Cursor(const std::vector<std::uint8_t>& bytes, std::uint64_t pos, bool v3, const std::string& name,
         const std::string& part)
      : bytes_(bytes), pos_(pos), v3_(v3), name_(name), part_(part) {}

  std::uint64_t pos() const { return pos_; }
  void skip(std::uint64_t n) { need(n), pos_ += n; }
  std::uint32_t u32() {
    need(4);
    const std::uint8_t* p = bytes_.data() + pos_;
    pos_ += 4;
    return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | p[3];
  }
  std::int32_t i32() { return static_cast<std::int32_t>(u32()); }
  std::uint64_t u64() {
    const std::uint64_t high = u32();
    return (high << 32) | u32();
  }
  /// An offset or record size: 8 bytes in CDF 3, 4 in CDF 2; a negative value is corrupt.
  std::uint64_t offset() {
    const std::uint64_t start = pos_;
    const std::int64_t v = v3_ ? static_cast<std::int64_t>(u64()) : static_cast<std::int64_t>(i32());
    if (v < 0) fail("negative offset or size " + std::to_string(v) + at_byte(start));
    return static_cast<std::uint64_t>(v);
  }
  /// An offset field that may hold -1 (none), unchecked.
  std::int64_t raw_offset() { return v3_ ? static_cast<std::int64_t>(u64()) : i32(); }
  /// A count that must lie in [0, max].
  std::int32_t count(const char* what, std::int32_t max) {
    const std::int32_t v = i32();
    if (v < 0 || v > max) fail(std::string(what) + " " + std::to_string(v) + " out of range");
    return v;
  }
  /// A fixed-length, NUL-padded name.
  std::string text(std::size_t n) {
    need(n);
    const char* p = reinterpret_cast<const char*>(bytes_.data() + pos_);
    pos_ += n;
    return std::string(p, strnlen(p, n));
  }
  const std::uint8_t* data(std::uint64_t n) {
    need(n);
    const std::uint8_t* p = bytes_.data() + pos_;
    pos_ += n;
    return p;
  }
  [[noreturn]] void fail(const std::string& problem) const { throw InputError(name_, "CDF " + part_ + ": " + problem); }

 private:
  void need(std::uint64_t n) const {
    if (pos_ > bytes_.size() || n > bytes_.size() - pos_) {
      fail("ends beyond the end of the file" + at_byte(bytes_.size()) + " (truncated or corrupt)");
    }
  }
  const std::vector<std::uint8_t>& bytes_;
  std::uint64_t pos_;
  bool v3_;
  const std::string& name_;
  std::string part_;
};

/// Reads the header of the internal record at `offset`: checks its type and that its size fits in
/// the file; returns a cursor just after the type, and the record's size in *size.
inline Cursor open_record(const std::vector<std::uint8_t>& bytes, std::uint64_t offset, bool v3,
                          const std::string& name, const std::string& part, std::int32_t type,
                          std::uint64_t* size = nullptr) {
  Cursor c(bytes, offset, v3, name, part + at_byte(offset));
  if (offset < 8 || offset >= bytes.size()) c.fail("offset outside the file (" + std::to_string(bytes.size()) + " bytes)");
  const std::uint64_t record_size = c.offset();
  const std::int32_t record_type = c.i32();
  if (record_type != type) {
    c.fail("record type " + std::to_string(record_type) + ", expected " + std::to_string(type) + " (corrupt file)");
  }
  if (record_size < (v3 ? 12u : 8u) || record_size > bytes.size() - offset) {
    c.fail("record size " + std::to_string(record_size) + " does not fit in the file (truncated or corrupt)");
  }
  if (size) *size = record_size;
  return c;
}

/// Element value at p in the file's byte order, as an unsigned integer of n bytes.
inline std::uint64_t load(const std::uint8_t* p, std::size_t n, bool little) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < n; ++i) v |= std::uint64_t{p[little ? i : n - 1 - i]} << (8 * i);
  return v;
}

/// One element of a numeric type as double; NaN for a type that is not numeric.
inline double decode_real(const std::uint8_t* p, int type, bool little) {
  switch (type) {
    case 1: case 41: return static_cast<std::int8_t>(p[0]);
    case 11: return p[0];
    case 2: return static_cast<std::int16_t>(load(p, 2, little));
    case 12: return static_cast<std::uint16_t>(load(p, 2, little));
    case 4: return static_cast<std::int32_t>(load(p, 4, little));
    case 14: return static_cast<std::uint32_t>(load(p, 4, little));
    case 8: case 33: return static_cast<double>(static_cast<std::int64_t>(load(p, 8, little)));
    case 21: case 44: {
      const auto bits = static_cast<std::uint32_t>(load(p, 4, little));
      float f;
      std::memcpy(&f, &bits, 4);
      return f;
    }
    case 22: case 45: case 31: case 32: {  // EPOCH16: the seconds part
      const std::uint64_t bits = load(p, 8, little);
      double d;
      std::memcpy(&d, &bits, 8);
      return d;
    }
    default: return std::numeric_limits<double>::quiet_NaN();
  }
}

}  // namespace magnetometer_insitu_calibration::cdf_detail
