// Shared helpers for the core gtests.
#pragma once
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace magnetometer_insitu_calibration::test {
/// A fresh empty directory under the system temp dir, removed by nobody (CI machines are clean).
std::string make_temp_dir(const std::string& tag);
/// Path of a file shipped in the package's data/ directory.
std::string package_data(const std::string& name);
/// Path of a file in test/data.
std::string test_data(const std::string& name);

/// Writes `bytes` to `path` as they are (binary), replacing the file.
void write_bytes(const std::string& path, const std::string& bytes);
/// The lines of a text file (or its .gz) as TextLineReader gives them, without line ends.
std::vector<std::string> read_lines(const std::string& path);
/// A JSON file parsed (a report of calibrate_records --json, an export's input).
nlohmann::json read_json(const std::string& path);
/// Whether `part` occurs in `text`.
bool contains(const std::string& text, const std::string& part);

/// How a program started by run_program ended.
struct ProgramRun {
  int status = -1;     ///< exit status; -1 when it did not exit normally (killed by a signal)
  std::string output;  ///< what it wrote to stdout and stderr
};
/// Runs `program args` through the shell as a user would, stderr joined to stdout, and waits
/// for it to end.
ProgramRun run_program(const std::string& program, const std::string& args);
}  // namespace magnetometer_insitu_calibration::test
