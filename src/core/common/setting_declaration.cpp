// Setting declarations: their checks, parsing and text (setting_declaration.hpp).
#include "magnetometer_insitu_calibration/common/setting_declaration.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace magnetometer_insitu_calibration {

namespace {

std::string number_text(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

bool text_kind(SettingKind kind) {
  return kind == SettingKind::kChoice || kind == SettingKind::kText || kind == SettingKind::kTopic ||
         kind == SettingKind::kPath || kind == SettingKind::kList;
}

SettingDeclaration declared(std::string key, std::string parameter, std::string option, SettingKind kind,
                            std::string unit, SettingValue value, std::string help) {
  SettingDeclaration d;
  d.key = std::move(key);
  d.parameter = std::move(parameter);
  d.option = std::move(option);
  d.kind = kind;
  d.unit = std::move(unit);
  d.default_value = std::move(value);
  d.help = std::move(help);
  return d;
}

}  // namespace

std::string SettingRange::text() const {
  const bool has_low = std::isfinite(low), has_high = std::isfinite(high);
  if (has_low && has_high) {
    return (low_open ? "(" : "[") + number_text(low) + ", " + number_text(high) + (high_open ? ")" : "]");
  }
  if (has_low) return (low_open ? "> " : ">= ") + number_text(low);
  if (has_high) return (high_open ? "< " : "<= ") + number_text(high);
  return "";
}

bool SettingRange::holds(double value) const {
  if (!std::isfinite(value)) return false;
  const bool low_ok = low_open ? value > low : value >= low;
  const bool high_ok = high_open ? value < high : value <= high;
  return low_ok && high_ok;
}

SettingRange above(double low) { return SettingRange{low, std::numeric_limits<double>::infinity(), true, false}; }
SettingRange at_least(double low) { return SettingRange{low, std::numeric_limits<double>::infinity(), false, false}; }
SettingRange between(double low, double high) { return SettingRange{low, high, false, false}; }

std::string setting_value_text(const SettingValue& value) {
  if (const double* number = std::get_if<double>(&value)) return number_text(*number);
  if (const long long* integer = std::get_if<long long>(&value)) return std::to_string(*integer);
  if (const bool* flag = std::get_if<bool>(&value)) return *flag ? "true" : "false";
  return std::get<std::string>(value);
}

std::string SettingDeclaration::default_text() const {
  if (!default_note.empty()) return default_note;
  if (required) return "required";
  const std::string text = setting_value_text(default_value);
  return text_kind(kind) && text.empty() ? "\"\"" : text;
}

std::string SettingDeclaration::option_default_text() const {
  return option_default_note.empty() ? default_text() : option_default_note;
}

std::string SettingDeclaration::problem(const SettingValue& value) const {
  const std::string unit_text = unit.empty() || unit == "-" ? "" : " " + unit;
  if (kind == SettingKind::kNumber || kind == SettingKind::kInteger) {
    double number = 0.0;
    if (const double* d = std::get_if<double>(&value)) number = *d;
    else if (const long long* i = std::get_if<long long>(&value)) number = static_cast<double>(*i);
    else return kind == SettingKind::kNumber ? "must be a number" : "must be a whole number";
    if (kind == SettingKind::kInteger && std::holds_alternative<double>(value)) return "must be a whole number";
    if (!std::isfinite(number)) return "must be a finite number, not " + number_text(number);
    if (!range.holds(number)) {
      const bool interval = std::isfinite(range.low) && std::isfinite(range.high);
      return std::string("must be ") + (interval ? "in " : "") + range.text() + unit_text + ", not " + number_text(number);
    }
    return "";
  }
  if (kind == SettingKind::kFlag) return std::holds_alternative<bool>(value) ? "" : "must be true or false";
  if (!std::holds_alternative<std::string>(value)) return "must be a string";
  const std::string& text = std::get<std::string>(value);
  if (kind == SettingKind::kChoice) {
    std::string expected;
    for (const std::string& c : choices) {
      if (c == text) return "";
      expected += (expected.empty() ? "" : " or ") + c;
    }
    return "expected " + expected + ", got '" + text + "'";
  }
  // A text whose default is not empty has no "none": it must not be empty either.
  const std::string* fallback = std::get_if<std::string>(&default_value);
  if (text.empty() && (required || (fallback != nullptr && !fallback->empty()))) return "must not be empty";
  return "";
}

SettingValue SettingDeclaration::parse(const std::string& text) const {
  std::size_t used = 0;
  switch (kind) {
    case SettingKind::kNumber: {
      double value = 0.0;
      try {
        value = std::stod(text, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used == 0 || used != text.size()) throw std::invalid_argument("expected a number, got '" + text + "'");
      return value;
    }
    case SettingKind::kInteger: {
      long long value = 0;
      try {
        value = std::stoll(text, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used == 0 || used != text.size()) throw std::invalid_argument("expected a whole number, got '" + text + "'");
      return value;
    }
    case SettingKind::kFlag:
      if (text == "true" || text == "1") return true;
      if (text == "false" || text == "0") return false;
      throw std::invalid_argument("expected true or false, got '" + text + "'");
    default:
      return text;
  }
}

SettingDeclaration number_setting(std::string key, std::string parameter, std::string option, std::string unit,
                                  double default_value, SettingRange range, std::string help) {
  SettingDeclaration d = declared(std::move(key), std::move(parameter), std::move(option), SettingKind::kNumber,
                                  std::move(unit), default_value, std::move(help));
  d.range = range;
  return d;
}

SettingDeclaration integer_setting(std::string key, std::string parameter, std::string option, std::string unit,
                                   long long default_value, SettingRange range, std::string help) {
  SettingDeclaration d = declared(std::move(key), std::move(parameter), std::move(option), SettingKind::kInteger,
                                  std::move(unit), default_value, std::move(help));
  d.range = range;
  return d;
}

SettingDeclaration flag_setting(std::string key, std::string parameter, std::string option, bool default_value,
                                std::string help) {
  return declared(std::move(key), std::move(parameter), std::move(option), SettingKind::kFlag, "", default_value,
                  std::move(help));
}

SettingDeclaration choice_setting(std::string key, std::string parameter, std::string option,
                                  std::vector<std::string> choices, std::string default_value, std::string help) {
  SettingDeclaration d = declared(std::move(key), std::move(parameter), std::move(option), SettingKind::kChoice, "",
                                  std::move(default_value), std::move(help));
  d.choices = std::move(choices);
  return d;
}

SettingDeclaration text_setting(SettingKind kind, std::string key, std::string parameter, std::string option,
                                std::string default_value, std::string help) {
  return declared(std::move(key), std::move(parameter), std::move(option), kind, "", std::move(default_value),
                  std::move(help));
}

const SettingDeclaration* find_setting(const SettingDeclarations& declarations, const std::string& key) {
  for (const SettingDeclaration& d : declarations)
    if (d.key == key) return &d;
  for (const SettingDeclaration& d : declarations)
    for (const std::string& alias : d.core_aliases)
      if (alias == key) return &d;
  return nullptr;
}

const SettingDeclaration* find_parameter(const SettingDeclarations& declarations, const std::string& parameter) {
  for (const SettingDeclaration& d : declarations)
    if (!parameter.empty() && d.parameter == parameter) return &d;
  return nullptr;
}

SettingDeclarations setting_group(const std::string& group, SettingDeclarations declarations) {
  for (SettingDeclaration& d : declarations) d.group = group;
  return declarations;
}

SettingDeclarations joined_settings(const std::vector<SettingDeclarations>& lists) {
  SettingDeclarations out;
  for (const SettingDeclarations& list : lists) out.insert(out.end(), list.begin(), list.end());
  return out;
}

}  // namespace magnetometer_insitu_calibration
