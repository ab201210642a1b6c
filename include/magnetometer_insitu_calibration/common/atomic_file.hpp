// Writing a file so that readers see the old or the new one, never a part: the calibration
// files of calibration_node, and any program's output that another process may read meanwhile.
#pragma once

#include <string>

namespace magnetometer_insitu_calibration {

/// Writes `text` to `path` atomically: a temporary file in the same directory, flushed to disk
/// (fsync), then renamed over `path`; readers see the old or the new file, never a part.
/// Throws std::runtime_error naming the file and the system error.
void write_file_atomically(const std::string& path, const std::string& text);

}  // namespace magnetometer_insitu_calibration
