// The command line of every program of src/cli and src/tools (CLI11), the exit status
// docs/programs.md gives for it, and the programs' warnings on stderr (one home for both folders).
#pragma once

#include <CLI/CLI.hpp>

#include <iostream>
#include <optional>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// Parses the command line into `app`. Empty when the program is to run; otherwise CLI11 has
/// printed the help (--help: status 0) or the usage error (status 1, whatever CLI11's own code:
/// 104-109 for a missing, unknown or bad option), and main returns the status.
inline std::optional<int> parse_command_line(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
    return std::nullopt;
  } catch (const CLI::ParseError& error) {
    return app.exit(error) == 0 ? 0 : 1;
  }
}

/// The readers' warnings (a last line dropped, LEMI records skipped, overlaps between files), each
/// on stderr as "<program>: warning: <warning>", alike in every program.
inline void print_warnings(const std::string& program, const std::vector<std::string>& warnings) {
  for (const std::string& warning : warnings) std::cerr << program << ": warning: " << warning << "\n";
}

}  // namespace magnetometer_insitu_calibration
