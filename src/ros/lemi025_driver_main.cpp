// lemi025_driver: see include/magnetometer_insitu_calibration/ros/lemi025_driver.hpp.
#include "magnetometer_insitu_calibration/ros/lemi025_driver.hpp"

#include "node_main.hpp"

int main(int argc, char** argv) {
  return magnetometer_insitu_calibration::run_node<magnetometer_insitu_calibration::Lemi025Driver>(argc, argv, "lemi025_driver");
}
