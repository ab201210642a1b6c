// Shared helpers of the libFuzzer targets (fuzz/fuzz_*.cpp). Not part of the package build.
//
// Contract checked by every target: any input gives either a value (which must satisfy the
// reader's documented invariants, checked with FUZZ_CHECK) or the reader's documented exception
// (InputError, or CalibrationFileError for the calibration YAML). Anything else (another
// exception, a sanitizer report, a timeout, a leak) is a finding: the target aborts.
#pragma once

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/lemi025_packet.hpp"
#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <zlib.h>

#include <cerrno>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>
#include <typeinfo>
#include <sys/mman.h>
#include <unistd.h>

namespace mic_fuzz {

/// Hard cap on one input, whatever -max_len says (per-input work stays bounded).
constexpr std::size_t kMaxInput = 1 << 16;
/// Largest text a gzip input may inflate to before the target declines it (a 64 KiB gzip
/// "bomb" would otherwise inflate to 64 MiB and make one execution take seconds).
constexpr std::size_t kMaxInflated = 1 << 20;

[[noreturn]] inline void fail(const char* file, int line, const std::string& what) {
  std::fprintf(stderr, "\n==FUZZ CHECK FAILED== %s:%d: %s\n", file, line, what.c_str());
  std::fflush(stderr);
  std::abort();
}

#define FUZZ_CHECK(condition, what)                                                   \
  do {                                                                                \
    if (!(condition)) ::mic_fuzz::fail(__FILE__, __LINE__, std::string(#condition) + \
                                                               " -- " + (what));     \
  } while (0)

/// An exception the reader does not document: report it and abort (libFuzzer saves the input).
[[noreturn]] inline void unexpected_exception(const char* file, int line) {
  try {
    throw;
  } catch (const std::exception& e) {
    fail(file, line, std::string("undocumented exception ") + typeid(e).name() + ": " + e.what());
  } catch (...) {
    fail(file, line, "undocumented non-std exception");
  }
}

/// The fuzz input as a file that the path-based readers can open: an anonymous memfd (no
/// directory entry, nothing left behind), reached by its /proc/self/fd path. Each open() of that
/// path gets its own file offset, so readers see the file from its start.
class InputFile {
 public:
  InputFile() {
    fd_ = static_cast<int>(::memfd_create("mic_fuzz_input", MFD_CLOEXEC));
    if (fd_ < 0) fail(__FILE__, __LINE__, std::string("memfd_create: ") + std::strerror(errno));
    path_ = "/proc/self/fd/" + std::to_string(fd_);
  }
  ~InputFile() { ::close(fd_); }
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;

  /// Replaces the content by `size` bytes.
  void set(const std::uint8_t* data, std::size_t size) {
    if (::ftruncate(fd_, 0) != 0) fail(__FILE__, __LINE__, "ftruncate");
    std::size_t done = 0;
    while (done < size) {
      const ssize_t n = ::pwrite(fd_, data + done, size - done, static_cast<off_t>(done));
      if (n <= 0) fail(__FILE__, __LINE__, "pwrite");
      done += static_cast<std::size_t>(n);
    }
  }
  const std::string& path() const { return path_; }

 private:
  int fd_ = -1;
  std::string path_;
};

/// One file per process, reused by every execution.
inline InputFile& input_file() {
  static InputFile file;
  return file;
}

/// Size of the text zlib's gzread would produce from `data` (gzip members back to back;
/// anything after the last member is ignored, as gzread does), stopping as soon as it exceeds
/// `limit`. Plain (non-gzip) input: its own size.
inline std::size_t inflated_size(const std::uint8_t* data, std::size_t size, std::size_t limit) {
  if (size < 2 || data[0] != 0x1f || data[1] != 0x8b) return size;
  z_stream z{};
  if (inflateInit2(&z, 16 + MAX_WBITS) != Z_OK) return 0;
  z.next_in = const_cast<Bytef*>(data);
  z.avail_in = static_cast<uInt>(size);
  std::size_t total = 0;
  unsigned char out[16384];
  for (;;) {
    z.next_out = out;
    z.avail_out = sizeof out;
    const int rc = inflate(&z, Z_NO_FLUSH);
    total += sizeof out - z.avail_out;
    if (total > limit) break;
    if (rc == Z_STREAM_END) {
      if (z.avail_in >= 2 && z.next_in[0] == 0x1f && z.next_in[1] == 0x8b) {
        inflateReset(&z);
        continue;
      }
      break;
    }
    if (rc != Z_OK) break;  // damaged or cut short: the reader reports it
  }
  inflateEnd(&z);
  return total;
}

/// True if the input is within the per-input bounds (size, inflated size for text readers).
inline bool within_bounds(const std::uint8_t* data, std::size_t size, bool text) {
  if (size > kMaxInput) return false;
  return !text || inflated_size(data, size, kMaxInflated) <= kMaxInflated;
}

/// The body of a target that reads the input as a file: declines an input beyond the bounds
/// (returns -1; `text`: its inflated size is bounded too), writes it to the in-memory file and
/// runs check(path), in which the reader's InputError is the documented refusal and any other
/// exception a finding (reported here). Returns 0 otherwise.
template <class Check>
int check_input_file(const std::uint8_t* data, std::size_t size, bool text, const Check& check) {
  if (!within_bounds(data, size, text)) return -1;
  InputFile& file = input_file();
  file.set(data, size);
  try {
    check(file.path());
  } catch (const magnetometer_insitu_calibration::InputError&) {
  } catch (...) {
    unexpected_exception(__FILE__, __LINE__);
  }
  return 0;
}

/// The invariants every VectorRecord returned by a reader must satisfy (vector_record.hpp):
/// times finite and strictly increasing, one row of values per time, values NaN or finite with
/// |value| <= max_abs_nT.
inline void check_record(const magnetometer_insitu_calibration::VectorRecord& record,
                         double max_abs_nT = HUGE_VAL) {
  FUZZ_CHECK(record.values_nT.rows() == static_cast<Eigen::Index>(record.time_s.size()),
             "rows of values != number of times");
  for (std::size_t i = 0; i < record.time_s.size(); ++i) {
    FUZZ_CHECK(std::isfinite(record.time_s[i]), "time not finite at row " + std::to_string(i));
    if (i > 0)
      FUZZ_CHECK(record.time_s[i] > record.time_s[i - 1],
                 "times not strictly increasing at row " + std::to_string(i));
    for (int c = 0; c < 3; ++c) {
      const double v = record.values_nT(static_cast<Eigen::Index>(i), c);
      FUZZ_CHECK(std::isnan(v) || (std::isfinite(v) && std::abs(v) <= max_abs_nT),
                 "value out of range at row " + std::to_string(i) + ": " + std::to_string(v));
    }
  }
}

/// The time invariants of a VectorRecord alone, for readers whose values are not range-checked
/// (a compact-flash card has no plausibility check): one row of values per time, times finite
/// and strictly increasing.
inline void check_record_times(const magnetometer_insitu_calibration::VectorRecord& record) {
  FUZZ_CHECK(record.values_nT.rows() == static_cast<Eigen::Index>(record.time_s.size()), "rows");
  for (std::size_t i = 0; i < record.time_s.size(); ++i) {
    FUZZ_CHECK(std::isfinite(record.time_s[i]), "time not finite");
    if (i > 0) FUZZ_CHECK(record.time_s[i] > record.time_s[i - 1], "times not increasing");
  }
}

/// The checksum mode the LEMI file targets try, taken from the input size so that the corpus
/// exercises all three without a configuration byte: size % 3 = 1 sum8, 2 xor8, 0 none.
inline magnetometer_insitu_calibration::ChecksumMode checksum_from_size(std::size_t size) {
  using magnetometer_insitu_calibration::ChecksumMode;
  return size % 3 == 1 ? ChecksumMode::kSum8 : size % 3 == 2 ? ChecksumMode::kXor8 : ChecksumMode::kNone;
}

/// The invariants of a record read from a text format (IAGA-2002, CSV): those of check_record,
/// at least one row (a file without data is an InputError), and every value below the 88888 nT
/// missing-data sentinel (the readers turn sentinels into NaN).
inline void check_text_record(const magnetometer_insitu_calibration::VectorRecord& record) {
  check_record(record);
  FUZZ_CHECK(!record.empty(), "no data but no InputError");
  for (Eigen::Index r = 0; r < record.values_nT.rows(); ++r)
    for (int c = 0; c < 3; ++c)
      FUZZ_CHECK(!(record.values_nT(r, c) >= 88888.0), "sentinel value not turned into NaN");
}

}  // namespace mic_fuzz
