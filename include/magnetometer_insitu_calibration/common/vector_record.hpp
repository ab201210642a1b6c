// A three-component magnetometer record: the common currency of the ROS-free core.
#pragma once

#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <map>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// N x 3 matrix of readings: one row per sample, columns x, y, z of the instrument frame, nT.
using Readings = Eigen::Matrix<double, Eigen::Dynamic, 3>;

/// One instrument's record. Times are UNIX seconds (UTC, leap seconds not counted) and strictly
/// increasing; values are in nanotesla; a missing reading is NaN (never a sentinel such as 99999).
struct VectorRecord {
  std::vector<double> time_s;                          ///< UNIX seconds, UTC
  Readings values_nT;                                  ///< N x 3, nT, NaN = missing
  std::array<std::string, 3> components{"X", "Y", "Z"};  ///< names of the three columns
  std::string source;                                  ///< file name or topic, for messages
  std::string station;                                 ///< IAGA code or station name, if known
  std::map<std::string, std::string> header;           ///< format metadata (IAGA header fields, ...)

  std::size_t size() const { return time_s.size(); }
  bool empty() const { return time_s.empty(); }
};

}  // namespace magnetometer_insitu_calibration
