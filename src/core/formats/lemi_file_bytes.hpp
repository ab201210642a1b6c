// Private to the LEMI readers: a whole file as bytes.
#pragma once

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <cstdint>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration::lemi_detail {

/// All bytes of `path`; throws InputError(path, "cannot open") if it cannot be read.
inline std::vector<std::uint8_t> read_file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "cannot open");
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                  std::istreambuf_iterator<char>());
  if (in.bad()) throw InputError(path, "read error");
  return bytes;
}

}  // namespace magnetometer_insitu_calibration::lemi_detail
