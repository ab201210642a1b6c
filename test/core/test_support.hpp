// Shared helpers for the core gtests.
#pragma once
#include <string>

namespace magnetometer_insitu_calibration::test {
/// A fresh empty directory under the system temp dir, removed by nobody (CI machines are clean).
std::string make_temp_dir(const std::string& tag);
/// Path of a file shipped in the package's data/ directory.
std::string package_data(const std::string& name);
/// Path of a file in test/data.
std::string test_data(const std::string& name);
}  // namespace magnetometer_insitu_calibration::test
