// Several files of one instrument (daily files, say) as one record.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// Joins records of one instrument in time order (parts sorted by their first time; the order
/// given does not matter). A sample at or before the last time already kept (files that overlap,
/// a file given twice, duplicated samples at a boundary) is dropped, and each part that loses
/// samples adds one warning naming it, the count and the time range ("<source>: 3600 samples
/// from ... to ... overlap <other source>: dropped (largest value difference 0.00 nT)").
/// A gap between files stays a gap: the pipeline fills or flags it as within one file.
/// Result: header, station and components of the earliest part; source = the sources joined by
/// " + "; auxiliary channels by name, NaN where a part lacks one. One part is returned as it is.
/// Throws InputError(source, ...) for no parts, or a part whose components differ from the first.
VectorRecord join_records(std::vector<VectorRecord> parts, std::vector<std::string>* warnings = nullptr);

/// read_record for each path, then join_records; the LEMI readers' warnings go to *warnings.
VectorRecord read_records(const std::vector<std::string>& paths, std::vector<std::string>* warnings = nullptr);

}  // namespace magnetometer_insitu_calibration
