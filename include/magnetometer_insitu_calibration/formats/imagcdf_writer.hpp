// Writing a VectorRecord as ImagCDF 1.2 (INTERMAGNET technical manual, "IMAGCDFV1.2 INTERMAGNET
// Exchange Format"), with cdf_writer.hpp.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <cmath>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// Global attributes of the file. Empty strings take the record's header values of the same
/// attribute name (as read from an ImagCDF or MagPy CDF), else the defaults given here.
struct ImagCdfWriteOptions {
  std::string iaga_code;          ///< IagaCode; default record.station, upper case
  std::string observatory_name;   ///< ObservatoryName; default the IAGA code
  /// NaN: the record's header Latitude/StationLatitude (etc.) if a number, else 99999 (unknown).
  double latitude = NAN;          ///< Latitude, degrees north (WGS-84)
  double longitude = NAN;         ///< Longitude, degrees east
  double elevation = NAN;         ///< Elevation, m
  std::string institution;        ///< Institution; default "unknown"
  std::string publication_level;  ///< PublicationLevel 1..4; default "2" (edited: a correction applied)
  std::string source;             ///< Source: institute (default), INTERMAGNET or WDC
  std::string terms_of_use;       ///< TermsOfUse; default the record's DataTerms or TermsOfUse, else none
  std::string vector_sens_orient; ///< VectorSensOrient; default the components, e.g. "HEZ"
  /// Non-standard global attribute "Comments": one entry per paragraph (e.g. the calibration applied).
  std::vector<std::string> comments;
  double publication_date_s = NAN;  ///< PublicationDate, UNIX s; NaN: the time of writing
  bool big_endian = false;          ///< data encoding NETWORK instead of IBMPC
  bool gzip = false;                ///< GZIP-compress each variable (ImagCDF allows any CDF compression)
};

/// Writes `record` as ImagCDF 1.2: global attributes FormatDescription "INTERMAGNET CDF Format",
/// FormatVersion "1.2", Title, IagaCode, ElementsRecorded (the three components, e.g. "HEZ"),
/// PublicationLevel, PublicationDate (CDF_TIME_TT2000), ObservatoryName, Latitude, Longitude,
/// Elevation, Institution, VectorSensOrient, StandardLevel "None", Source, TermsOfUse (if any),
/// Comments (if any); variables GeomagneticField<E> (CDF_DOUBLE, nT, FILLVAL 99999 for NaN,
/// VALIDMIN -79999, VALIDMAX 79999, DEPEND_0 GeomagneticVectorTimes), GeomagneticVectorTimes
/// (CDF_TIME_TT2000), and for each auxiliary channel Temperature<n> (degC, FILLVAL 99999,
/// VALIDMIN -273.15, VALIDMAX 1000, FIELDNAM its description or name, DEPEND_0 Temperature<n>Times,
/// a copy of the vector times). Nothing is written if the record cannot be: throws
/// InputError(path, ...) for an empty record, a component name that is not one letter, a time
/// before 1972, times not strictly increasing at nanosecond resolution, or a value outside
/// VALIDMIN..VALIDMAX.
void write_imagcdf(const std::string& path, const VectorRecord& record, const ImagCdfWriteOptions& options = {});

}  // namespace magnetometer_insitu_calibration
