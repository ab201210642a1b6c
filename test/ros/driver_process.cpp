// The driver as a child process of a test: see driver_process.hpp.
#include "driver_process.hpp"

#include <signal.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>

namespace magnetometer_insitu_calibration {
namespace test {

std::string driver_path() {
  char self[4096] = {0};
  const ssize_t n = ::readlink("/proc/self/exe", self, sizeof(self) - 1);
  const std::string exe = n > 0 ? std::string(self, static_cast<std::size_t>(n)) : std::string();
  return exe.substr(0, exe.rfind('/')) + "/lemi025_driver";
}

DriverProcess::DriverProcess(const std::string& ns, const std::vector<std::string>& parameters) {
  std::vector<std::string> args = {driver_path(), "__name:=replay", "__ns:=" + ns};
  args.insert(args.end(), parameters.begin(), parameters.end());
  pid_ = ::fork();
  if (pid_ == 0) {
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(&a[0]);
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
}

DriverProcess::~DriverProcess() {
  if (pid_ <= 0) return;
  ::kill(pid_, SIGINT);
  int status = 0;
  for (int i = 0; i < 500 && ::waitpid(pid_, &status, WNOHANG) == 0; ++i) ::usleep(10000);
  if (::waitpid(pid_, &status, WNOHANG) == 0) {
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, &status, 0);
  }
}

std::string temporary_path(const std::string& stem) {
  const char* home = std::getenv("ROS_HOME");
  return std::string(home ? home : "/tmp") + "/" + stem + "_" + std::to_string(::getpid());
}

RunResult run_driver(const std::string& name, const std::string& arguments) {
  const std::string command = "timeout 30 " + driver_path() + " __name:=" + name + " " + arguments + " 2>&1";
  RunResult result;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return result;
  char buffer[512];
  while (std::fgets(buffer, sizeof(buffer), pipe)) result.output += buffer;
  const int status = ::pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

}  // namespace test
}  // namespace magnetometer_insitu_calibration
