// Reading a record file whatever its format, recognised from the content.
#pragma once

#include "magnetometer_insitu_calibration/vector_record.hpp"

#include <string>

namespace magnetometer_insitu_calibration {

enum class RecordFormat { kIaga2002, kCsv };

/// "IAGA-2002", "CSV".
const char* record_format_name(RecordFormat format);

/// Looks at the first non-blank line (plain or gzip): a line starting with "Format" after
/// blanks (IAGA-2002 has " Format" in column 1) and containing "IAGA-2002" (any case) marks an
/// IAGA-2002 file; anything else, including an empty file, is taken as CSV.
/// Throws InputError(path, "cannot open: ...") for a missing file.
RecordFormat detect_record_format(const std::string& path);

/// detect_record_format, then read_iaga2002 or read_csv_record.
VectorRecord read_record(const std::string& path);

}  // namespace magnetometer_insitu_calibration
