// An absolute scalar magnetometer's record (proton, Overhauser or optically pumped: F = |B| in
// nT, 1 nT absolute at an INTERMAGNET observatory), on its own times: what checks the reference's
// scale along the main field (estimation/scalar_check.hpp). Read by formats/scalar_record.hpp.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

struct ScalarRecord {
  std::vector<double> time_s;    ///< UNIX s, UTC, strictly increasing (any rate, off whole seconds)
  std::vector<double> value_nT;  ///< F, nT; NaN = missing
  std::string source;            ///< file name, for messages
  std::string station;           ///< IAGA code or instrument, if known

  std::size_t size() const { return time_s.size(); }
};

}  // namespace magnetometer_insitu_calibration
