// The command line of every program (CLI11) and the exit status docs/programs.md gives for it.
#pragma once

#include <CLI/CLI.hpp>

#include <optional>

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

}  // namespace magnetometer_insitu_calibration
