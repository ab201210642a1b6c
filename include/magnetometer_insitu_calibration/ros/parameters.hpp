// Reading private ROS parameters once at start-up, with errors that name the parameter.
#pragma once

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/setting_bindings.hpp"

#include <ros/node_handle.h>

#include <optional>

#include <stdexcept>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// An impossible or missing parameter. what() reads "parameter ~<name>: <problem>"; the node's
/// main prints it with ROS_FATAL and exits non-zero.
class ParameterError : public std::runtime_error {
 public:
  ParameterError(const std::string& name, const std::string& problem)
      : std::runtime_error("parameter ~" + name + ": " + problem), name_(name) {}
  const std::string& name() const { return name_; }

 private:
  std::string name_;
};

/// Reads ~name from the private node handle, or returns `fallback` when it is not set.
/// Throws ParameterError when the parameter is set with the wrong type (e.g. a string for a
/// number). Integers are accepted for doubles.
double param_double(const ros::NodeHandle& private_nh, const std::string& name, double fallback);
int param_int(const ros::NodeHandle& private_nh, const std::string& name, int fallback);
bool param_bool(const ros::NodeHandle& private_nh, const std::string& name, bool fallback);
std::string param_string(const ros::NodeHandle& private_nh, const std::string& name,
                         const std::string& fallback);
/// A string that must be set and not empty (topic names, file names).
std::string required_string(const ros::NodeHandle& private_nh, const std::string& name);

/// Throws ParameterError naming ~name unless `topic` is a non-empty, valid ROS graph name.
void require_topic_name(const std::string& name, const std::string& topic);

/// A number as text for messages, e.g. 0.25 or 1e-06.
std::string number_text(double value);


/// Private parameters set on the master under this node's name that are not in `known`
/// (first path component after ~), e.g. a misspelt "~windwo". For a start-up warning.
std::vector<std::string> unknown_private_parameters(const ros::NodeHandle& private_nh,
                                                    const std::vector<std::string>& known);

/// ~parameter of `declared` as its kind reads it (numbers: int or double; flags; strings), checked
/// against the declaration (range, choices, a valid topic name); nullopt when it is not set.
/// Throws ParameterError naming the parameter.
std::optional<SettingValue> read_declared(const ros::NodeHandle& private_nh, const SettingDeclaration& declared);

/// A core check's error (InputError::where = a settings key) named by the parameter that sets it.
ParameterError parameter_error(const InputError& error, const SettingDeclarations& declarations);

/// The private parameters the declarations name (for unknown_private_parameters).
std::vector<std::string> declared_parameters(const SettingDeclarations& declarations);

/// Every bound setting with a parameter that is set on the server: read, checked and set in
/// `root`. Settings not set keep root's value (the declared default).
template <class Root>
void load_declared(const ros::NodeHandle& private_nh, const SettingBindings<Root>& bindings, Root& root) {
  for (const SettingBinding<Root>& b : bindings.bindings()) {
    if (b.declared.parameter.empty()) continue;
    const std::optional<SettingValue> value = read_declared(private_nh, b.declared);
    if (!value) continue;
    try {
      b.set(root, *value);
    } catch (const InputError& e) {
      throw ParameterError(b.declared.parameter, e.problem());
    }
  }
}

}  // namespace magnetometer_insitu_calibration
