// The driver as a child process of a test: see driver_process.hpp.
#include "driver_process.hpp"

#include <stdlib.h>

namespace magnetometer_insitu_calibration {
namespace test {

std::string driver_path() { return sibling_executable("lemi025_driver"); }

DriverProcess::DriverProcess(const std::string& ns, const std::vector<std::string>& parameters) {
  std::vector<std::string> args = {"__name:=replay", "__ns:=" + ns};
  args.insert(args.end(), parameters.begin(), parameters.end());
  pid_ = spawn_process(driver_path(), args);
}

DriverProcess::~DriverProcess() { stop_process(pid_, 5.0); }

std::string temporary_path(const std::string& stem) {
  const char* home = std::getenv("ROS_HOME");
  return std::string(home ? home : "/tmp") + "/" + stem + "_" + std::to_string(::getpid());
}

RunResult run_driver(const std::string& name, const std::string& arguments) {
  return run_to_exit(driver_path() + " __name:=" + name + " " + arguments);
}

}  // namespace test
}  // namespace magnetometer_insitu_calibration
