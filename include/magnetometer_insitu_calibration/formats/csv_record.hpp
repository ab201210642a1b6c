// Delimited-text records: one sample per line, "time,x,y,z[,aux...]" (time in UNIX seconds or
// ISO 8601 UTC, values in nT, auxiliary channels such as a temperature in deg C).
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"  // TextReadOptions

#include <string>

namespace magnetometer_insitu_calibration {

/// Reads a CSV record, plain or gzip-compressed (detected from the content).
/// - Lines that are blank or whose first non-blank character is '#' are skipped; the text of the
///   '#' lines is kept in header["comments"], joined by '\n'.
/// - The first other line may be a header "time,x,y,z": when its first field is not a time it is
///   a header, and its 2nd..4th names become the component names (default "X", "Y", "Z").
/// - Columns after the fourth (e.g. "time,X,Y,Z,temperature") need that header: each becomes an
///   auxiliary channel of the record, named as in the header; a name containing "temperature"
///   (any case) has unit "degC". Values: numbers, empty or "nan" for missing.
/// - Delimiter: whichever of ',' ';' or tab occurs most in that first line (',' on a tie).
///   Fields are trimmed; surrounding double quotes are removed (no quoting of delimiters).
/// - Time column: UNIX seconds (a number) or ISO 8601 UTC (see parse_iso8601); times must
///   strictly increase.
/// - Values in nT; an empty field, "nan" (any case) or a value >= 88888 (IAGA sentinel) is NaN.
/// Throws InputError(path, line, "column N (<name>): ...") for a bad field, a wrong number of
/// columns or a time not after the previous one; InputError(path, ...) for a missing file or a
/// file without data lines. `options`: a file still being written, a clock that steps
/// (text_lines.hpp); with complete_lines_only a file without a data line yet is an empty record.
VectorRecord read_csv_record(const std::string& path, const TextReadOptions& options = TextReadOptions());

/// Writes "time,<c1>,<c2>,<c3>" then one line per sample, LF line ends, gzip when the path ends
/// in ".gz"; first the lines of record.header["comments"] as "# " lines, if any. Auxiliary
/// channels follow the three components as named columns (shortest exact form, "nan" missing).
/// Time: ISO 8601 with 3, 6 or 9 decimals (the fewest that read back exactly, for every sample)
/// when iso_time, else UNIX seconds in the shortest form that reads back exactly.
/// Values: fixed-point with `decimals` (0..17) digits, NaN as "nan".
/// Nothing is written if the record cannot be: throws InputError(path, problem) for an empty
/// record, times not finite or not strictly increasing, a value that is infinite or would read
/// back as missing (>= 88888 nT), a component name with a delimiter, quote or newline.
void write_csv_record(const std::string& path, const VectorRecord& record, bool iso_time = true,
                      int decimals = 3);

}  // namespace magnetometer_insitu_calibration
