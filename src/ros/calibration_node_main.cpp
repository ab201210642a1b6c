// calibration_node: see include/magnetometer_insitu_calibration/ros/calibration_node.hpp.
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"

#include "node_main.hpp"

int main(int argc, char** argv) {
  return magnetometer_insitu_calibration::run_node<magnetometer_insitu_calibration::CalibrationNode>(argc, argv, "calibration_node");
}
