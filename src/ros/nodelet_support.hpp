// Shared by the nodelets of src/ros/*_nodelet.cpp: builds a node class from a nodelet's handles.
#pragma once

#include <ros/ros.h>

#include <exception>
#include <memory>
#include <string>

namespace magnetometer_insitu_calibration {

/// Constructs Node(nh, private_nh). An impossible parameter (ParameterError, naming it) is logged
/// as FATAL under the nodelet's name, as the executables do, and rethrown: the manager then
/// reports the load as failed (and `nodelet load` exits) instead of keeping a nodelet that does
/// nothing.
template <class Node>
std::unique_ptr<Node> construct_node(const std::string& nodelet_name, ros::NodeHandle nh, ros::NodeHandle private_nh) {
  try {
    return std::make_unique<Node>(nh, private_nh);
  } catch (const std::exception& error) {
    ROS_FATAL("%s: %s", nodelet_name.c_str(), error.what());
    throw;
  }
}

}  // namespace magnetometer_insitu_calibration
