// record_file_follower: see include/magnetometer_insitu_calibration/ros/record_file_follower.hpp.
#include "magnetometer_insitu_calibration/ros/record_file_follower.hpp"

#include "node_main.hpp"

int main(int argc, char** argv) {
  return magnetometer_insitu_calibration::run_node<magnetometer_insitu_calibration::RecordFileFollowerNode>(
      argc, argv, "record_file_follower");
}
