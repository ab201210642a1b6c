// Reading private ROS parameters once at start-up, with errors that name the parameter.
#pragma once

#include <ros/node_handle.h>

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

/// Range checks that throw ParameterError naming the parameter.
void require_positive(const std::string& name, double value, const std::string& unit);
void require_non_negative(const std::string& name, double value, const std::string& unit);
void require_in_range(const std::string& name, double value, double low, double high);

/// Private parameters set on the master under this node's name that are not in `known`
/// (first path component after ~), e.g. a misspelt "~windwo". For a start-up warning.
std::vector<std::string> unknown_private_parameters(const ros::NodeHandle& private_nh,
                                                    const std::vector<std::string>& known);

}  // namespace magnetometer_insitu_calibration
