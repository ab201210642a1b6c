// scalar_simulator: see include/magnetometer_insitu_calibration/ros/scalar_simulator.hpp.
#include "magnetometer_insitu_calibration/ros/scalar_simulator.hpp"

#include "node_main.hpp"

int main(int argc, char** argv) {
  return magnetometer_insitu_calibration::run_node<magnetometer_insitu_calibration::ScalarSimulator>(argc, argv, "scalar_simulator");
}
