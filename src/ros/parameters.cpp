// Private parameter reading with errors that name the parameter.
#include "magnetometer_insitu_calibration/ros/parameters.hpp"

#include <ros/names.h>

#include <algorithm>
#include <cmath>

namespace magnetometer_insitu_calibration {

namespace {

template <typename T>
T read(const ros::NodeHandle& nh, const std::string& name, const T& fallback, const char* expected) {
  if (!nh.hasParam(name)) return fallback;
  T value{};
  if (!nh.getParam(name, value)) throw ParameterError(name, std::string("must be ") + expected);
  return value;
}

}  // namespace

std::string number_text(double value) { return setting_value_text(value); }

void require_topic_name(const std::string& name, const std::string& topic) {
  if (topic.empty()) throw ParameterError(name, "must not be empty");
  std::string error;
  if (!ros::names::validate(topic, error)) throw ParameterError(name, "'" + topic + "' is not a valid topic name: " + error);
}

double param_double(const ros::NodeHandle& nh, const std::string& name, double fallback) {
  const double value = read<double>(nh, name, fallback, "a number");
  if (!std::isfinite(value)) throw ParameterError(name, "must be a finite number, not " + number_text(value));
  return value;
}

int param_int(const ros::NodeHandle& nh, const std::string& name, int fallback) {
  return read<int>(nh, name, fallback, "an integer");
}

bool param_bool(const ros::NodeHandle& nh, const std::string& name, bool fallback) {
  return read<bool>(nh, name, fallback, "true or false");
}

std::string param_string(const ros::NodeHandle& nh, const std::string& name, const std::string& fallback) {
  return read<std::string>(nh, name, fallback, "a string");
}

std::string required_string(const ros::NodeHandle& nh, const std::string& name) {
  if (!nh.hasParam(name)) throw ParameterError(name, "is required and not set");
  const std::string value = param_string(nh, name, "");
  if (value.empty()) throw ParameterError(name, "must not be empty");
  return value;
}

std::optional<SettingValue> read_declared(const ros::NodeHandle& nh, const SettingDeclaration& declared) {
  const std::string& name = declared.parameter;
  if (!nh.hasParam(name)) {
    if (declared.required) throw ParameterError(name, "is required and not set");
    return std::nullopt;
  }
  SettingValue value;
  switch (declared.kind) {
    case SettingKind::kNumber: value = param_double(nh, name, 0.0); break;
    case SettingKind::kInteger: value = static_cast<long long>(param_int(nh, name, 0)); break;
    case SettingKind::kFlag: value = param_bool(nh, name, false); break;
    default: value = param_string(nh, name, ""); break;
  }
  const std::string problem = declared.problem(value);
  if (!problem.empty()) throw ParameterError(name, problem);
  if (declared.kind == SettingKind::kTopic && !std::get<std::string>(value).empty()) {
    require_topic_name(name, std::get<std::string>(value));
  }
  return value;
}

ParameterError parameter_error(const InputError& error, const SettingDeclarations& declarations) {
  const SettingDeclaration* d = find_setting(declarations, error.where());
  return ParameterError(d != nullptr && !d->parameter.empty() ? d->parameter : error.where(), error.problem());
}

std::vector<std::string> declared_parameters(const SettingDeclarations& declarations) {
  std::vector<std::string> names;
  for (const SettingDeclaration& d : declarations)
    if (!d.parameter.empty()) names.push_back(d.parameter);
  return names;
}

std::vector<std::string> unknown_private_parameters(const ros::NodeHandle& nh,
                                                    const std::vector<std::string>& known) {
  std::vector<std::string> names, unknown;
  if (!nh.getParamNames(names)) return unknown;
  const std::string prefix = nh.getNamespace() + "/";
  for (const std::string& full : names) {
    if (full.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string rest = full.substr(prefix.size());
    const std::string first = rest.substr(0, rest.find('/'));
    if (std::find(known.begin(), known.end(), first) == known.end() &&
        std::find(unknown.begin(), unknown.end(), first) == unknown.end()) {
      unknown.push_back(first);
    }
  }
  return unknown;
}

}  // namespace magnetometer_insitu_calibration
