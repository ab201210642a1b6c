// The nodes' parameters are their declarations (pipeline/setting_declarations.hpp,
// instrument/lemi025_driver_settings.hpp, formats/record_follower_settings.hpp): every declared parameter is read, each bound one's
// declared default is the settings struct's own, and the unknown-parameter warning knows exactly
// the declared names.
#include "magnetometer_insitu_calibration/formats/record_follower_settings.hpp"
#include "magnetometer_insitu_calibration/instrument/lemi025_driver_settings.hpp"
#include "magnetometer_insitu_calibration/pipeline/setting_declarations.hpp"
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"
#include "magnetometer_insitu_calibration/ros/correction_node.hpp"
#include "magnetometer_insitu_calibration/ros/lemi025_driver.hpp"
#include "magnetometer_insitu_calibration/ros/parameters.hpp"
#include "magnetometer_insitu_calibration/ros/record_file_follower.hpp"

#include <gtest/gtest.h>

#include <set>
#include <string>

namespace mic = magnetometer_insitu_calibration;

namespace {

/// Every declaration with a parameter is bound, or read by the node's own code (`by_hand`); a
/// bound one's declared default is the struct's default (unless its default is a note).
template <class Settings>
void expect_declared_and_bound(const mic::SettingDeclarations& declarations, const mic::SettingBindings<Settings>& bound,
                               const std::set<std::string>& by_hand) {
  const Settings defaults;
  for (const mic::SettingDeclaration& d : declarations) {
    if (d.parameter.empty()) continue;
    const auto* b = bound.find(d.key);
    if (by_hand.count(d.parameter) != 0) {
      EXPECT_EQ(b, nullptr) << d.parameter << " is both bound and read by hand";
      continue;
    }
    ASSERT_NE(b, nullptr) << "~" << d.parameter << " is declared and not read";
    if (!d.default_note.empty() || d.required) continue;
    EXPECT_EQ(mic::setting_value_text(b->get(defaults)), mic::setting_value_text(d.default_value)) << d.parameter;
  }
}

}  // namespace

TEST(NodeSettings, CalibrationNodeReadsEveryDeclaredParameter) {
  expect_declared_and_bound(mic::calibration_setting_declarations(), mic::CalibrationNodeSettings::bindings(),
                            {"reference_topic", "test_topic", "test_name", "calibration_topic", "calibration_file",
                             "temperature_topic", "tests", "remote_topic", "scalar_topic", "tolerance_file"});
  const std::vector<std::string>& known = mic::CalibrationNodeSettings::known_parameters();
  EXPECT_EQ(known, mic::declared_parameters(mic::calibration_setting_declarations()));
  EXPECT_EQ(std::set<std::string>(known.begin(), known.end()).size(), known.size());
}

TEST(NodeSettings, CorrectionNodeDriverAndFollowerReadEveryDeclaredParameter) {
  expect_declared_and_bound(mic::correction_setting_declarations(), mic::CorrectionNodeSettings::bindings(), {});
  expect_declared_and_bound(mic::lemi025_driver_setting_declarations(), mic::Lemi025DriverSettings::bindings(), {});
  expect_declared_and_bound(mic::record_file_follower_setting_declarations(),
                            mic::RecordFileFollowerSettings::bindings(), {});
}

// A core check's error, named by the key of its field, reaches the user under the parameter.
TEST(NodeSettings, ACoreErrorIsNamedByTheParameter) {
  const mic::ParameterError e =
      mic::parameter_error(mic::InputError("section_s", "must be a positive time in s"), mic::calibration_setting_declarations());
  EXPECT_STREQ(e.what(), "parameter ~section_length: must be a positive time in s");
  const mic::ParameterError alias =
      mic::parameter_error(mic::InputError("tolerance_s", "too wide"), mic::calibration_setting_declarations());
  EXPECT_EQ(alias.name(), "pairing_tolerance");
}
