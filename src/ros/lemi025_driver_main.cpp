// lemi025_driver: see include/magnetometer_insitu_calibration/ros/lemi025_driver.hpp.
#include "magnetometer_insitu_calibration/ros/lemi025_driver.hpp"

int main(int argc, char** argv) {
  ros::init(argc, argv, "lemi025_driver");
  ros::NodeHandle nh, private_nh("~");  // outlive the node: the last NodeHandle gone shuts ROS (and its logging) down
  try {
    magnetometer_insitu_calibration::Lemi025Driver node{nh, private_nh};
    ros::spin();
  } catch (const std::exception& error) {  // ParameterError names the parameter
    ROS_FATAL("%s: %s", ros::this_node::getName().c_str(), error.what());
    return 1;
  }
  return 0;
}
