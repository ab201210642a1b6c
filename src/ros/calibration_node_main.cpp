// calibration_node: see include/magnetometer_insitu_calibration/ros/calibration_node.hpp.
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"

int main(int argc, char** argv) {
  ros::init(argc, argv, "calibration_node");
  // These handles outlive the node: destroying the last NodeHandle shuts roscpp and its logging
  // down, and the fatal message below would be lost.
  ros::NodeHandle nh, private_nh("~");
  try {
    magnetometer_insitu_calibration::CalibrationNode node(nh, private_nh);
    ros::spin();
  } catch (const std::exception& error) {  // ParameterError names the parameter
    ROS_FATAL("%s: %s", ros::this_node::getName().c_str(), error.what());
    return 1;
  }
  return 0;
}
