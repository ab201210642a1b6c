// lemi025_driver started by a test itself (test_lemi025_driver's recordings and impossible
// parameters): the executable next to the test's, a child process in its own namespace, and
// temporary file names under $ROS_HOME.
#pragma once

#include "child_process.hpp"

#include <sys/types.h>

#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {
namespace test {

/// Path of lemi025_driver: catkin puts it next to the test executable (devel/lib/<package>).
std::string driver_path();

/// lemi025_driver as node "replay" in namespace `ns` with command-line private parameters
/// ("_name:=value"); SIGINT on destruction (SIGKILL if it has not exited 5 s later).
class DriverProcess {
 public:
  DriverProcess(const std::string& ns, const std::vector<std::string>& parameters);
  ~DriverProcess();
  DriverProcess(const DriverProcess&) = delete;
  DriverProcess& operator=(const DriverProcess&) = delete;
  bool started() const { return pid_ > 0; }

 private:
  pid_t pid_ = -1;
};

/// $ROS_HOME (or /tmp) / <stem>_<pid>.
std::string temporary_path(const std::string& stem);

/// Runs the driver as node `name` with command-line `arguments` to its exit (at most 30 s).
RunResult run_driver(const std::string& name, const std::string& arguments);

}  // namespace test
}  // namespace magnetometer_insitu_calibration
