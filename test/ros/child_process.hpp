// Programs a test starts itself (a node stopped and started again, a node given impossible
// parameters): a child process with command-line arguments, stopped as roslaunch stops a node
// (SIGINT, then SIGKILL if it hangs), or run to its exit with its output.
#pragma once

#include <signal.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

namespace magnetometer_insitu_calibration {
namespace test {

/// Path of the package's executable `name`: catkin puts it next to the test executable
/// (devel/lib/<package>).
inline std::string sibling_executable(const std::string& name) {
  char self[4096] = {0};
  const ssize_t n = ::readlink("/proc/self/exe", self, sizeof(self) - 1);
  const std::string exe = n > 0 ? std::string(self, static_cast<std::size_t>(n)) : std::string();
  return exe.substr(0, exe.rfind('/')) + "/" + name;
}

/// Starts `program` with `arguments` (stdout and stderr shared with the test); its pid.
inline pid_t spawn_process(const std::string& program, const std::vector<std::string>& arguments) {
  std::vector<std::string> all{program};
  all.insert(all.end(), arguments.begin(), arguments.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(&a[0]);
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::execv(program.c_str(), argv.data());
    ::_exit(127);
  }
  return pid;
}

/// SIGINT (as roslaunch does), then waits up to timeout_s wall seconds; SIGKILL if it hangs.
/// True when it exited by itself.
inline bool stop_process(pid_t pid, double timeout_s = 15.0) {
  if (pid <= 0) return false;
  ::kill(pid, SIGINT);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  int status = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    if (::waitpid(pid, &status, WNOHANG) == pid) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, &status, 0);
  return false;
}

/// A started process, stopped when the test returns (also on a failed ASSERT).
struct ChildProcess {
  pid_t pid = -1;
  ~ChildProcess() { stop(); }
  bool stop(double timeout_s = 15.0) {
    const bool clean = stop_process(pid, timeout_s);
    pid = -1;
    return clean;
  }
};

struct RunResult {
  int exit_code = -1;   ///< -1 when it did not exit normally
  std::string output;   ///< stdout and stderr
};

/// Runs the shell command `command` to its exit (at most timeout_s), stderr joined to stdout.
inline RunResult run_to_exit(const std::string& command, int timeout_s = 30) {
  RunResult result;
  FILE* pipe = ::popen(("timeout " + std::to_string(timeout_s) + " " + command + " 2>&1").c_str(), "r");
  if (!pipe) return result;
  char buffer[512];
  while (std::fgets(buffer, sizeof(buffer), pipe)) result.output += buffer;
  const int status = ::pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

}  // namespace test
}  // namespace magnetometer_insitu_calibration
