// Writing a file so that readers see the old or the new one, never a part: the calibration
// files of calibration_node, and any program's output that another process may read meanwhile.
#pragma once

#include <string>

namespace magnetometer_insitu_calibration {

/// Writes `text` to `path` atomically: a temporary file in the same directory, flushed to disk
/// (fsync), then renamed over `path`; readers see the old or the new file, never a part.
/// Throws std::runtime_error naming the file and the system error.
void write_file_atomically(const std::string& path, const std::string& text);

/// Makes `path` writable by write_file_atomically before anything is to be written: creates its
/// missing parent directories (mode 0755, as `mkdir -p`), then creates and removes the temporary
/// file a write would use. Leaves an existing `path` untouched. Throws std::runtime_error naming
/// the directory or file and the system error (for example a read-only or missing mount).
void prepare_file_directory(const std::string& path);

}  // namespace magnetometer_insitu_calibration
