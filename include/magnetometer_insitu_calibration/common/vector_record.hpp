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

/// A channel recorded beside the field, one value per sample of the record (NaN = missing), e.g.
/// the sensor temperature. Only the readers fill it and only the archive tools use it; the
/// estimation and preprocessing ignore it (a record they cut or resample drops it).
struct AuxiliaryChannel {
  std::string name;         ///< as in the file, e.g. "t1", "Temperature1"
  std::string description;  ///< e.g. "T_sensor"; may be empty
  std::string unit;         ///< e.g. "degC"
  std::vector<double> values;  ///< size() == time_s.size()
};

/// One instrument's record. Times are UNIX seconds (UTC, leap seconds not counted) and strictly
/// increasing; values are in nanotesla; a missing reading is NaN (never a sentinel such as 99999).
struct VectorRecord {
  std::vector<double> time_s;                          ///< UNIX seconds, UTC
  Readings values_nT;                                  ///< N x 3, nT, NaN = missing
  std::array<std::string, 3> components{"X", "Y", "Z"};  ///< names of the three columns
  std::string source;                                  ///< file name or topic, for messages
  std::string station;                                 ///< IAGA code or station name, if known
  std::map<std::string, std::string> header;           ///< format metadata (IAGA header fields, ...)
  std::vector<AuxiliaryChannel> auxiliary;             ///< temperatures etc., where the format has them

  std::size_t size() const { return time_s.size(); }
  bool empty() const { return time_s.empty(); }
};

}  // namespace magnetometer_insitu_calibration
