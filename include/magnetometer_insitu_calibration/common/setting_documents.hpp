// The documents printed from the setting declarations: a node's config/*.yaml block, a node's
// parameter table and a program's option table (Markdown), each between markers in its file:
//   YAML:     "# <settings NAME>" ... "# </settings>"
//   Markdown: "<!-- settings NAME -->" ... "<!-- /settings -->"
// print_settings rewrites the blocks; its --check (a test) fails when a file's block differs.
#pragma once

#include "magnetometer_insitu_calibration/common/setting_declaration.hpp"

#include <string>

namespace magnetometer_insitu_calibration {

/// Every declaration with a parameter as a YAML line under its group's heading: a number, flag or
/// choice with a plain default is set ("window: 86400  # [s, > 0] window length"); a text, a
/// topic, a file or a noted default is shown commented out.
std::string settings_yaml(const SettingDeclarations& declarations);

/// | parameter | unit | default | range | meaning |, one row per declaration with a parameter.
std::string parameter_table(const SettingDeclarations& declarations);

/// | option | unit | default | range | meaning |, one row per declaration with an option (a flag
/// as --x / --no-x; two declarations of one option as LOW:HIGH).
std::string option_table(const SettingDeclarations& declarations);

enum class BlockStyle { kYaml, kMarkdown };

/// The text between the block's markers (without them). Throws std::runtime_error naming the
/// block when the markers are missing.
std::string marked_block(const std::string& document, const std::string& name, BlockStyle style);
/// `document` with the block's text replaced.
std::string with_marked_block(const std::string& document, const std::string& name, BlockStyle style,
                              const std::string& block);

}  // namespace magnetometer_insitu_calibration
