// Shared by the executables of src/ros/*_main.cpp: runs a node class (as the nodelets of
// nodelet_support.hpp construct it) until shutdown.
#pragma once

#include <ros/ros.h>

#include <cstdio>
#include <cstring>
#include <exception>

namespace magnetometer_insitu_calibration {

/// ros::init under `name`, then Node(nh, private_nh) and ros::spin(). An impossible parameter
/// (ParameterError, naming it) or a device that cannot be opened is logged as FATAL under the
/// node's name and the process exits 1. The handles outlive the node: destroying the last
/// NodeHandle shuts roscpp and its logging down, and the fatal message would be lost.
///
/// stdout is line-buffered: rosconsole writes INFO there, and where stdout is not a terminal
/// (roslaunch > station.log, a systemd journal, a pipe) the C library would otherwise hold the
/// lines in 4 KB blocks, so a station's one line per window arrived in bursts or at exit.
/// `--help` / `-h` prints where the node's parameters are documented instead of waiting for a
/// master.
template <class Node>
int run_node(int argc, char** argv, const char* name) {
  std::setvbuf(stdout, nullptr, _IOLBF, BUFSIZ);
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--help") == 0 || std::strcmp(argv[i], "-h") == 0) {
      std::printf("%s: a ROS node of magnetometer_insitu_calibration; start it with rosrun or roslaunch.\n"
                  "Private parameters (_name:=value on the command line, or in a launch file): every one with its\n"
                  "unit and default in the package's config/, described in docs/nodes.md.\n",
                  name);
      return 0;
    }
  }
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
