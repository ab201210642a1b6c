// Writing a CDF 3 file (the package's own encoder): single file, row major, optionally GZIP
// compressed per variable and/or as a whole,
// zVariables of 0 dimensions holding CDF_DOUBLE or CDF_TIME_TT2000, one VXR and one VVR per
// variable, global and variable attributes (text, doubles or TT2000). Data in little endian
// (IBMPC encoding) or big endian (NETWORK encoding); internal records big endian as always.
#pragma once

#include "magnetometer_insitu_calibration/formats/cdf_file.hpp"

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace magnetometer_insitu_calibration {

/// An attribute entry to write: text (CDF_CHAR) when `numbers` and `times` are empty, else
/// CDF_DOUBLE `numbers` or CDF_TIME_TT2000 `times`.
struct CdfWriteEntry {
  std::string text;
  std::vector<double> numbers;
  std::vector<std::int64_t> times;
  static CdfWriteEntry of_text(std::string t) { return {std::move(t), {}, {}}; }
  static CdfWriteEntry of_number(double v) { return {"", {v}, {}}; }
  static CdfWriteEntry of_time(std::int64_t tt2000) { return {"", {}, {tt2000}}; }
};

struct CdfWriteVariable {
  std::string name;
  int data_type = kCdfDouble;          ///< kCdfDouble or kCdfEpoch (ms) in values; kCdfTimeTt2000 in times
  std::vector<double> values;
  std::vector<std::int64_t> times;     ///< TT2000 ns
  std::vector<std::pair<std::string, CdfWriteEntry>> attributes;  ///< FIELDNAM, UNITS, FILLVAL, ...
};

struct CdfWriteContent {
  /// Global attributes in order; each with one or more entries.
  std::vector<std::pair<std::string, std::vector<CdfWriteEntry>>> global;
  std::vector<CdfWriteVariable> variables;
  bool big_endian = false;
  bool gzip_variables = false;  ///< each variable's values GZIP-compressed (CPR + CVVR)
  bool gzip_file = false;       ///< the whole file GZIP-compressed (CCR + CPR), as MagPy writes
  int version = 3;              ///< 3 (CDF 3.9) or 2 (CDF 2.7: 4-byte offsets, 64-character names)
};

/// The bytes of the CDF file. Throws InputError("CDF writer", ...) for a name longer than 256
/// characters (64 in CDF 2), a version other than 2 or 3, or a variable whose data type is not
/// CDF_DOUBLE, CDF_EPOCH or CDF_TIME_TT2000.
std::vector<std::uint8_t> encode_cdf(const CdfWriteContent& content);

/// encode_cdf, written to `path` (replaced). Throws InputError(path, ...) when it cannot be written.
void write_cdf(const std::string& path, const CdfWriteContent& content);

}  // namespace magnetometer_insitu_calibration
