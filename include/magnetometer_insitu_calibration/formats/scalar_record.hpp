// Reading an absolute scalar magnetometer's record (common/scalar_record.hpp) from the formats
// observatories keep it in.
#pragma once

#include "magnetometer_insitu_calibration/common/scalar_record.hpp"

#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// Reads F from: a MagPy CDF (variable f on its DEPEND_0 time), an ImagCDF (GeomagneticFieldF
/// on GeomagneticScalarTimes, else the vector times), an IAGA-2002 file (its fourth column when
/// it is F: values >= 88888 missing) or a CSV of "time,F" (time as UNIX seconds or ISO 8601; a
/// header line allowed). Samples whose time cannot be read are dropped; times that do not
/// increase are refused. Throws InputError(path[:line], ...) naming the problem.
ScalarRecord read_scalar_record(const std::string& path);

/// Several files (daily files) in time order: each read, then joined; an overlap is refused.
ScalarRecord read_scalar_records(const std::vector<std::string>& paths);

}  // namespace magnetometer_insitu_calibration
