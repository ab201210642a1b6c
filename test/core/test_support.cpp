#include "test_support.hpp"

#include <cstdlib>
#include <filesystem>
#include <stdexcept>

namespace magnetometer_insitu_calibration::test {

std::string make_temp_dir(const std::string& tag) {
  std::string pattern =
      (std::filesystem::temp_directory_path() / ("mic_" + tag + "_XXXXXX")).string();
  if (mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed for " + pattern);
  return pattern;
}

std::string package_data(const std::string& name) { return std::string(PACKAGE_DATA_DIR) + "/" + name; }
std::string test_data(const std::string& name) { return std::string(TEST_DATA_DIR) + "/" + name; }

}  // namespace magnetometer_insitu_calibration::test
