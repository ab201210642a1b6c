// Magnetometer records in CDF files: the two layouts observatories use.
//  - MagPy CDF (MagPy's archive format, global attribute DataFormat "MagPyCDF..."): variables
//    x, y, z (nT) on the time variable named by their DEPEND_0 (else "time" or "Epoch"), optional
//    t1, t2 (temperatures, degC) and f; components from the global attribute DataComponents
//    ("HEZ" -> H, E, Z; default X, Y, Z); station from StationIAGAcode (else StationID).
//    DataCompensationX/Y/Z (the bias fields removed by the instrument) are kept in the header:
//    the values are returned as stored, compensation not added back.
//  - ImagCDF (INTERMAGNET): variables GeomagneticField<E> for the first three vector elements of
//    ElementsRecorded (F, S and G are scalar elements and skipped; an angle, D or I or UNITS in
//    degrees, is refused: the calibration needs field components), on their DEPEND_0 time variable
//    (GeomagneticVectorTimes; DataTimes in ImagCDF 1.0 files without DEPEND_0); Temperature<n>
//    on their own DEPEND_0 times, interpolated linearly to the vector times (NaN outside them and
//    next to a missing value); station from IagaCode.
// Times: CDF_TIME_TT2000 (leap seconds from the table of cdf_epoch.hpp), CDF_EPOCH or CDF_EPOCH16.
// A record whose time is the fill value, or falls inside a leap second (23:59:60, which has no
// UNIX time), is dropped; their count is in header "cdf_records_dropped". A value equal to the
// variable's FILLVAL, outside [VALIDMIN, VALIDMAX] or infinite is NaN.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"
#include "magnetometer_insitu_calibration/formats/cdf_file.hpp"

#include <string>

namespace magnetometer_insitu_calibration {

/// Reads a MagPy CDF or ImagCDF file. header: every global attribute (text, entries joined by
/// '\n') under its own name, plus "cdf_layout" ("MagPy CDF" or "ImagCDF") and
/// "cdf_records_dropped"; auxiliary: the temperatures (MagPy t1, t2; ImagCDF Temperature<n>).
/// Throws InputError(path, ...) for a CDF that is neither layout (naming the variables it holds),
/// a missing time or field variable, a time variable of another type, times not increasing, or
/// anything CdfFile::open refuses.
VectorRecord read_cdf_record(const std::string& path);

/// The same from a parsed file (fuzzing, tests).
VectorRecord cdf_to_vector_record(const CdfFile& file);

}  // namespace magnetometer_insitu_calibration
