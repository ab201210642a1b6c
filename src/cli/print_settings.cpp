// print_settings: the documents of the declared settings (common/setting_documents.hpp).
//   print_settings             print every block
//   print_settings --check DIR exit 1, naming the file and block, when a block in DIR's files differs
//   print_settings --write DIR rewrite the blocks in DIR's files
// DIR is the package's source folder (config/*.yaml, docs/nodes.md, docs/programs.md).
#include "magnetometer_insitu_calibration/common/setting_documents.hpp"
#include "magnetometer_insitu_calibration/formats/record_follower_settings.hpp"
#include "magnetometer_insitu_calibration/instrument/lemi025_driver_settings.hpp"
#include "magnetometer_insitu_calibration/pipeline/setting_declarations.hpp"

#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

struct Block {
  std::string file;  ///< relative to the package's folder
  std::string name;
  mic::BlockStyle style;
  std::string text;
};

std::vector<Block> blocks() {
  const mic::SettingDeclarations& calibration = mic::calibration_setting_declarations();
  const mic::SettingDeclarations& correction = mic::correction_setting_declarations();
  const mic::SettingDeclarations& driver = mic::lemi025_driver_setting_declarations();
  const mic::SettingDeclarations& follower = mic::record_file_follower_setting_declarations();
  using S = mic::BlockStyle;
  return {
      {"config/calibration.yaml", "calibration_node", S::kYaml, mic::settings_yaml(calibration)},
      {"config/correction.yaml", "correction_node", S::kYaml, mic::settings_yaml(correction)},
      {"config/lemi025_driver.yaml", "lemi025_driver", S::kYaml, mic::settings_yaml(driver)},
      {"config/record_file_follower.yaml", "record_file_follower", S::kYaml, mic::settings_yaml(follower)},
      {"docs/nodes.md", "calibration_node", S::kMarkdown, mic::parameter_table(calibration)},
      {"docs/nodes.md", "correction_node", S::kMarkdown, mic::parameter_table(correction)},
      {"docs/nodes.md", "lemi025_driver", S::kMarkdown, mic::parameter_table(driver)},
      {"docs/nodes.md", "record_file_follower", S::kMarkdown, mic::parameter_table(follower)},
      {"docs/programs.md", "calibrate_records", S::kMarkdown, mic::option_table(calibration)},
  };
}

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot read");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

/// The first line where two texts differ, 1-based, with both lines.
std::string first_difference(const std::string& found, const std::string& expected) {
  std::istringstream a(found), b(expected);
  std::string line_a, line_b;
  for (int line = 1;; ++line) {
    const bool more_a = static_cast<bool>(std::getline(a, line_a));
    const bool more_b = static_cast<bool>(std::getline(b, line_b));
    if (!more_a && !more_b) return "";
    if (!more_a || !more_b || line_a != line_b) {
      return "line " + std::to_string(line) + " of the block:\n  file:         " + (more_a ? line_a : "(end)") +
             "\n  declarations: " + (more_b ? line_b : "(end)");
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "";
  if (mode.empty()) {
    for (const Block& b : blocks()) std::cout << "== " << b.file << " (" << b.name << ")\n" << b.text << "\n";
    return 0;
  }
  if ((mode != "--check" && mode != "--write") || argc != 3) {
    std::cerr << "usage: print_settings [--check DIR | --write DIR]\n";
    return 1;
  }
  const std::string root = std::string(argv[2]) + "/";
  int differing = 0;
  try {
    for (const Block& b : blocks()) {
      const std::string document = read_file(root + b.file);
      const std::string found = mic::marked_block(document, b.name, b.style);
      if (found == b.text) continue;
      if (mode == "--write") {
        std::ofstream(root + b.file) << mic::with_marked_block(document, b.name, b.style, b.text);
        std::cout << "print_settings: wrote " << b.file << " (" << b.name << ")\n";
      } else {
        ++differing;
        std::cerr << "print_settings: " << b.file << " (" << b.name << ") differs from the declarations at "
                  << first_difference(found, b.text) << "\n";
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "print_settings: " << e.what() << "\n";
    return 1;
  }
  if (differing > 0) {
    std::cerr << "print_settings: " << differing << " block(s) differ; run print_settings --write on the package's folder "
              << "after changing a declaration (pipeline/setting_declarations.hpp, the instruments' and the follower's)\n";
    return 1;
  }
  return 0;
}
