// The calibration's declared settings against the settings structs they set
// (pipeline/setting_declarations.hpp): each declared default is the struct's own, and every
// value a declaration refuses is refused by the core's check of the same field too, under the
// same key, so that the library's guard and the front ends' rule are one rule.
#include "magnetometer_insitu_calibration/pipeline/setting_declarations.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <string>

namespace mic = magnetometer_insitu_calibration;

namespace {

/// A value at an end of the declared range: just outside it, or the last value inside.
std::optional<mic::SettingValue> at_edge(const mic::SettingDeclaration& d, bool low_end, bool inside) {
  const double edge = low_end ? d.range.low : d.range.high;
  if (!std::isfinite(edge)) return std::nullopt;
  const bool open = low_end ? d.range.low_open : d.range.high_open;
  const double step = d.kind == mic::SettingKind::kInteger ? 1.0 : std::max(1e-6, 1e-3 * std::abs(edge));
  const double inward = low_end ? step : -step;
  const double value = inside ? (open ? edge + inward : edge) : (open ? edge : edge - inward);
  if (d.kind == mic::SettingKind::kInteger) return mic::SettingValue(static_cast<long long>(std::llround(value)));
  return mic::SettingValue(value);
}

/// Rules only the front ends have: the core's layout takes a window of 0 s for "no window", and
/// its noise figure is a spectrum, not the figure in pT.
const std::set<std::string> kFrontEndOnly = {"window", "step", "intervals", "reference_noise_figure"};

}  // namespace

TEST(SettingDeclarations, EachKeyParameterAndOptionIsDeclaredOnce) {
  for (const mic::SettingDeclarations* list :
       {&mic::calibration_setting_declarations(), &mic::correction_setting_declarations()}) {
    std::set<std::string> keys, parameters, options;
    for (const mic::SettingDeclaration& d : *list) {
      EXPECT_TRUE(keys.insert(d.key).second) << d.key;
      if (!d.parameter.empty()) EXPECT_TRUE(parameters.insert(d.parameter).second) << d.parameter;
      if (!d.option.empty() && d.option != "--band") EXPECT_TRUE(options.insert(d.option).second) << d.option;
      EXPECT_FALSE(d.help.empty()) << d.key;
      EXPECT_FALSE(d.group.empty()) << d.key;
      if (!d.required && d.kind != mic::SettingKind::kList && d.default_note.empty()) {
        EXPECT_EQ(d.problem(d.default_value), "") << d.key << ": the declared default is refused by its own rule";
      }
    }
  }
}

TEST(SettingDeclarations, TheDeclaredDefaultsAreTheStructsDefaults) {
  const mic::CalibrationSettings defaults;
  for (const auto& b : mic::calibration_settings_bindings().bindings()) {
    const mic::SettingDeclaration& d = b.declared;
    if (!d.default_note.empty() || !d.option_default_note.empty()) continue;  // a default of its own words
    EXPECT_EQ(mic::setting_value_text(b.get(defaults)), mic::setting_value_text(d.default_value)) << d.key;
  }
}

TEST(SettingDeclarations, TheCoreRefusesWhatTheDeclarationRefusesUnderTheSameKey) {
  int checked = 0;
  for (const auto& b : mic::calibration_settings_bindings().bindings()) {
    const mic::SettingDeclaration& d = b.declared;
    if (kFrontEndOnly.count(d.key) != 0) continue;
    for (const bool low_end : {true, false}) {
      const std::optional<mic::SettingValue> value = at_edge(d, low_end, false);
      if (!value) continue;
      ASSERT_NE(d.problem(*value), "") << d.key;
      mic::CalibrationSettings s;
      b.set(s, *value);
      try {
        s.validate();
        ADD_FAILURE() << d.key << " = " << mic::setting_value_text(*value) << " passes the core's check";
      } catch (const mic::InputError& e) {
        const mic::SettingDeclaration* named = mic::find_setting(mic::calibration_setting_declarations(), e.where());
        ASSERT_NE(named, nullptr) << d.key << ": the core names '" << e.where() << "'";
        EXPECT_EQ(named->key, d.key) << e.what();
      }
      ++checked;
    }
  }
  EXPECT_GE(checked, 20);
}

TEST(SettingDeclarations, TheCoreAcceptsTheDeclaredRangesEnds) {
  // The band's top is also above its bottom: a rule between two settings.
  const std::set<std::string> between_settings = {"band_high_hz"};
  for (const auto& b : mic::calibration_settings_bindings().bindings()) {
    const mic::SettingDeclaration& d = b.declared;
    if (between_settings.count(d.key) != 0 || kFrontEndOnly.count(d.key) != 0) continue;
    for (const bool low_end : {true, false}) {
      const std::optional<mic::SettingValue> value = at_edge(d, low_end, true);
      if (!value) continue;
      ASSERT_EQ(d.problem(*value), "") << d.key;
      mic::CalibrationSettings s;
      b.set(s, *value);
      try {
        s.validate();
      } catch (const mic::InputError& e) {
        ADD_FAILURE() << d.key << " = " << mic::setting_value_text(*value) << " is refused by the core: " << e.what();
      }
    }
  }
}
