// Shared by the executables of src/ros/*_main.cpp: runs a node class (as the nodelets of
// nodelet_support.hpp construct it) until shutdown.
#pragma once

#include <ros/ros.h>

#include <exception>

namespace magnetometer_insitu_calibration {

/// ros::init under `name`, then Node(nh, private_nh) and ros::spin(). An impossible parameter
/// (ParameterError, naming it) or a device that cannot be opened is logged as FATAL under the
/// node's name and the process exits 1. The handles outlive the node: destroying the last
/// NodeHandle shuts roscpp and its logging down, and the fatal message would be lost.
template <class Node>
int run_node(int argc, char** argv, const char* name) {
  ros::init(argc, argv, name);
  ros::NodeHandle nh, private_nh("~");
  try {
    Node node(nh, private_nh);
    ros::spin();
  } catch (const std::exception& error) {
    ROS_FATAL("%s: %s", ros::this_node::getName().c_str(), error.what());
    return 1;
  }
  return 0;
}

}  // namespace magnetometer_insitu_calibration
