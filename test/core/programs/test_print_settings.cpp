// config/*.yaml and the parameter tables of docs/nodes.md and docs/programs.md are the
// declarations' (print_settings --check); a changed line in a copy is found and named.
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace fs = std::filesystem;
using magnetometer_insitu_calibration::test::run_program;

TEST(PrintSettings, TheDocumentsInTheTreeAreTheDeclarations) {
  const auto r = run_program(PRINT_SETTINGS_BIN, "--check .");  // the tests run in the package's folder
  EXPECT_EQ(r.status, 0) << r.output;
}

TEST(PrintSettings, AYamlDefaultOrATableRowThatDiffersIsNamed) {
  const fs::path copy = fs::temp_directory_path() / "mic_print_settings_check";
  fs::remove_all(copy);
  fs::create_directories(copy / "config");
  fs::create_directories(copy / "docs");
  for (const char* file : {"config/calibration.yaml", "config/correction.yaml", "config/lemi025_driver.yaml",
                           "config/record_file_follower.yaml", "docs/nodes.md", "docs/programs.md"}) {
    fs::copy_file(file, copy / file);
  }
  std::ifstream in(copy / "config/calibration.yaml");
  std::stringstream text;
  text << in.rdbuf();
  in.close();
  std::string yaml = text.str();
  const std::size_t at = yaml.find("\nhuber_k: 2.0");
  ASSERT_NE(at, std::string::npos);
  yaml.replace(at, 13, "\nhuber_k: 1.5");
  std::ofstream(copy / "config/calibration.yaml") << yaml;
  auto r = run_program(PRINT_SETTINGS_BIN, "--check " + copy.string());
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("config/calibration.yaml (calibration_node) differs"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("huber_k: 1.5"), std::string::npos) << r.output;
  r = run_program(PRINT_SETTINGS_BIN, "--write " + copy.string());
  EXPECT_EQ(r.status, 0) << r.output;
  r = run_program(PRINT_SETTINGS_BIN, "--check " + copy.string());
  EXPECT_EQ(r.status, 0) << r.output;
  fs::remove_all(copy);
}
