// scalar_simulator: see include/magnetometer_insitu_calibration/ros/scalar_simulator.hpp.
#include "magnetometer_insitu_calibration/ros/scalar_simulator.hpp"

int main(int argc, char** argv) {
  ros::init(argc, argv, "scalar_simulator");
  ros::NodeHandle nh, private_nh("~");  // outlive the node, so that the fatal message is logged
  try {
    magnetometer_insitu_calibration::ScalarSimulator node(nh, private_nh);
    ros::spin();
  } catch (const std::exception& error) {  // ParameterError names the parameter
    ROS_FATAL("%s: %s", ros::this_node::getName().c_str(), error.what());
    return 1;
  }
  return 0;
}
