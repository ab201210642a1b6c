// An absolute scalar magnetometer's record (proton, Overhauser or optically pumped: F = |B| in
// nT, 1 nT absolute at an INTERMAGNET observatory), on its own times: what checks the reference's
// scale along the main field (estimation/scalar_check.hpp).
#pragma once

#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

struct ScalarRecord {
  std::vector<double> time_s;  ///< UNIX s, UTC, strictly increasing (any rate, off whole seconds)
  std::vector<double> value_nT;  ///< F, nT; NaN = missing
  std::string source;            ///< file name, for messages
  std::string station;           ///< IAGA code or instrument, if known

  std::size_t size() const { return time_s.size(); }
};

/// Reads F from: a MagPy CDF (variable f on its DEPEND_0 time), an ImagCDF (GeomagneticFieldF
/// on GeomagneticScalarTimes, else the vector times), an IAGA-2002 file (its fourth column when
/// it is F: values >= 88888 missing) or a CSV of "time,F" (time as UNIX seconds or ISO 8601; a
/// header line allowed). Samples whose time cannot be read are dropped; times that do not
/// increase are refused. Throws InputError(path[:line], ...) naming the problem.
ScalarRecord read_scalar_record(const std::string& path);

/// Several files (daily files) in time order: each read, then joined; an overlap is refused.
ScalarRecord read_scalar_records(const std::vector<std::string>& paths);

}  // namespace magnetometer_insitu_calibration
