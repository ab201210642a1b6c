// correction_node: see include/magnetometer_insitu_calibration/ros/correction_node.hpp.
#include "magnetometer_insitu_calibration/ros/correction_node.hpp"

#include "node_main.hpp"

int main(int argc, char** argv) {
  return magnetometer_insitu_calibration::run_node<magnetometer_insitu_calibration::CorrectionNode>(argc, argv, "correction_node");
}
