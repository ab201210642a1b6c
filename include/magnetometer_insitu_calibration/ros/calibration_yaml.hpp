// The calibration file: one MagnetometerCalibration as YAML, written atomically by
// calibration_node (latest accepted window) and loaded by correction_node.
//
// Format (format_version kCalibrationFileFormat): "stamp" and "frame_id" (the header), then one
// key per field of pipeline/calibration_record.hpp, in its order, with the message's names and
// units. Times as {secs, nsecs} (they load back exactly) with an ISO 8601 comment; doubles with 17
// significant digits (every number loads back bit for bit). Older formats still load: the fields
// a format lacks (their `since` is above it) get the meaning they had before they were written
// (calibration_yaml.cpp, fill_older_format). Every field is required, so a file cut short
// anywhere is refused as a whole.
#pragma once

#include "magnetometer_insitu_calibration/common/atomic_file.hpp"

#include <magnetometer_insitu_calibration/MagnetometerCalibration.h>

#include <stdexcept>
#include <string>

namespace magnetometer_insitu_calibration {

/// A calibration file that cannot be used. what() names the file and the problem.
class CalibrationFileError : public std::runtime_error {
 public:
  explicit CalibrationFileError(const std::string& what) : std::runtime_error(what) {}
};

/// YAML text of a calibration; `written_by` (e.g. the node name) goes into a comment-like key.
std::string calibration_to_yaml(const MagnetometerCalibration& calibration, const std::string& written_by);

/// Parses the YAML text; `source` (file name) is used in error messages. header.seq is 0.
/// Throws CalibrationFileError for malformed YAML, a missing field, a wrong type or length.
MagnetometerCalibration calibration_from_yaml(const std::string& text, const std::string& source);

/// Reads and parses a file; throws CalibrationFileError (naming the file) when it cannot be
/// read or parsed.
MagnetometerCalibration load_calibration_file(const std::string& path);


/// True when every field of a and b is equal (header.seq ignored); `difference` names the
/// first field that differs.
bool calibrations_equal(const MagnetometerCalibration& a, const MagnetometerCalibration& b,
                        std::string* difference = nullptr);

}  // namespace magnetometer_insitu_calibration
