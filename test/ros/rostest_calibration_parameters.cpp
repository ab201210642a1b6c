// rostest_calibration, bad_parameters.test (Calibration.BadParameters): calibration_node,
// correction_node and scalar_simulator started with impossible parameters exit 1 with a FATAL
// naming the parameter; the nodes' console lines reach a pipe while they run, and --help answers
// without a master.
#include "calibration_harness.hpp"
#include "child_process.hpp"

#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>

using namespace calibration_rostest;

namespace {

using mic::test::RunResult;

RunResult run(const std::string& command) { return mic::test::run_to_exit(command); }

}  // namespace

TEST(Calibration, BadParameters) {
  const std::string calibration = CALIBRATION_NODE_PATH, correction = CORRECTION_NODE_PATH;
  const std::string scalar = SCALAR_SIMULATOR_PATH;
  const std::string ok = " _reference_topic:=/r _test_topic:=/t _calibration_file:=/tmp/unused.yaml";
  struct Case {
    std::string command, expected;
  };
  const std::vector<Case> cases = {
      {calibration + " __name:=bad_step" + ok + " _window:=3600 _step:=7200", "parameter ~step: (7200 s) is longer than ~window"},
      {calibration + " __name:=bad_window" + ok + " _window:=-3600", "parameter ~window: must be > 0 s"},
      {calibration + " __name:=bad_band" + ok + " _band_low:=0.01 _band_high:=0.005", "parameter ~band_high:"},
      {calibration + " __name:=minute_band" + ok + " _input_period:=60",
       "parameter ~band_high: the band's top 0.01 Hz is above the Nyquist frequency 0.00833333 Hz of the 60 s"},
      {calibration + " __name:=bad_short" + ok + " _window:=600 _step:=60", "parameter ~window: (600 s) holds only"},
      // The rule of calibrate_records' --window and --intervals, in its words: which length would do.
      {calibration + " __name:=bad_short_hint" + ok + " _window:=600 _step:=60", "s or longer hold them"},
      {calibration + " __name:=bad_type" + ok + " _step:=ten", "parameter ~step: must be a number"},
      {calibration + " __name:=no_reference _test_topic:=/t _calibration_file:=/tmp/x.yaml", "parameter ~reference_topic: is required"},
      {calibration + " __name:=no_file _reference_topic:=/r _test_topic:=/t", "parameter ~calibration_file: is required"},
      // A directory that cannot be made (inside a regular file): refused at start, not a day later.
      {calibration + " __name:=unwritable_file _reference_topic:=/r _test_topic:=/t _calibration_file:=" + calibration +
           "/mic/fge.yaml",
       "parameter ~calibration_file: " + calibration + "/mic/fge.yaml: cannot create directory " + calibration + "/mic"},
      {calibration + " __name:=bad_tolerance" + ok + " _pairing_tolerance:=0.7", "parameter ~pairing_tolerance:"},
      // Streams of other rates: a remote's period without a remote, a remote whose pairs with the
      // reference would come every 30 s beside a 1 s pair, a kernel too short for a 1 s stream.
      {calibration + " __name:=lone_remote_period" + ok + " _remote_input_period:=1",
       "parameter ~remote_input_period: is used with ~remote_topic only"},
      {calibration + " __name:=slow_remote" + ok + " _remote_topic:=/m _remote_input_period:=30",
       "parameter ~remote_input_period: of 30 s puts the remote onto the epochs every 30 s, the tests' pairs every 1 s"},
      {calibration + " __name:=short_kernel" + ok + " _test_input_period:=0.1 _decimation_sigma:=0.01",
       "parameter ~test_input_period: of 1 s: the filter's kernel (half-width 0.04 s) is shorter than it"},
      // A list of tests is no command-line value: set on the master first, as a launch file does.
      {"rosparam set /slow_listed_test/tests '[{name: a, topic: /a, calibration_file: /tmp/unused_a.yaml}, "
       "{name: b, topic: /b, calibration_file: /tmp/unused_b.yaml, input_period: 30}]' && " +
           calibration + " __name:=slow_listed_test _reference_topic:=/r",
       "parameter ~tests[1].input_period: of 30 s puts the test's pairs with the reference every 30 s, the others' every 1 s"},
      {"rosparam set /unlike_hat_tests/tests '[{name: a, topic: /a, calibration_file: /tmp/unused_a.yaml}, "
       "{name: b, topic: /b, calibration_file: /tmp/unused_b.yaml, input_period: 0.1}]' && " +
           calibration + " __name:=unlike_hat_tests _reference_topic:=/r",
       "parameter ~tests[1].input_period: puts this test's windows through the Gaussian FIR where tests[0]'s are not"},
      {calibration + " __name:=bad_method" + ok + " _method:=fast", "parameter ~method:"},
      {calibration + " __name:=bad_eiv" + ok + " _eiv:=deming", "parameter ~eiv:"},
      {calibration + " __name:=bad_noise" + ok + " _reference_noise_pT:=-10", "parameter ~reference_noise_pT:"},
      {calibration + " __name:=bad_ratio" + ok + " _eiv:=ratio", "parameter ~eiv: expected given or none"},
      {calibration + " __name:=bad_huber" + ok + " _huber_k:=-1", "parameter ~huber_k:"},
      {calibration + " __name:=bad_section" + ok + " _section_length:=-5", "parameter ~section_length:"},
      {calibration + " __name:=bad_delay" + ok + " _estimate_delay:=false", "parameter ~correct_delay:"},
      {calibration + " __name:=bad_tf_suffix" + ok + " _tf_child_frame_suffix:=a/b", "parameter ~tf_child_frame_suffix:"},
      {calibration + " __name:=bad_temperature_topic" + ok + " _temperature_topic:=/t", "parameter ~temperature_topic: '/t' is a magnetic field"},
      {calibration + " __name:=bad_temperature_name" + ok + " _temperature_topic:='a b'", "parameter ~temperature_topic:"},
      {calibration + " __name:=bad_temperature_range" + ok + " _temperature_min_range:=-1", "parameter ~temperature_min_range:"},
      {calibration + " __name:=lone_direction" + ok + " _field_direction:=1.3,63.4", "parameter ~field_direction: is used with ~scalar_topic only"},
      {calibration + " __name:=bad_direction" + ok + " _scalar_topic:=/f _field_direction:=1.3,93", "parameter ~field_direction: expected D,I or D,I,hdz"},
      {correction + " __name:=bad_temperature_age _test_topic:=/t _temperature_topic:=/temp _temperature_max_age:=0", "parameter ~temperature_max_age:"},
      {correction + " __name:=bad_temperature_model _test_topic:=/t _temperature_model:=linear", "parameter ~temperature_model:"},
      {correction + " __name:=bad_offset _test_topic:=/t _apply_offset:=maybe", "parameter ~apply_offset:"},
      {correction + " __name:=no_test_topic", "parameter ~test_topic: is required"},
      {scalar + " __name:=bad_scalar_period _period:=0", "parameter ~period: must be 0.1 to 3600 s"},
      {scalar + " __name:=bad_scalar_start _start:=yesterday", "parameter ~start:"},
      {scalar + " __name:=bad_scalar_seed _seed:=0", "parameter ~seed: must be >= 1"},
      {correction + " __name:=bad_queue _test_topic:=/t _queue_size:=0", "parameter ~queue_size:"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.command);
    const RunResult r = run(c.command);
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_NE(r.output.find(c.expected), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("FATAL"), std::string::npos) << r.output;
  }
}

// calibration_node's console lines (rosconsole INFO, on stdout) arrive while it runs where stdout
// is a pipe or a file (roslaunch > station.log, a systemd journal), not in 4 KB blocks or at exit:
// its three start lines, a few hundred bytes, are read from a pipe before the node is stopped.
TEST(Calibration, ConsoleLinesReachAPipeWhileTheNodeRuns) {
  const std::string command = std::string(CALIBRATION_NODE_PATH) +
                              " __name:=console_pipe _reference_topic:=/r _test_topic:=/t "
                              "_calibration_file:=/tmp/console_pipe_unused.yaml";
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::dup2(fds[1], STDOUT_FILENO);
    ::close(fds[0]);
    ::close(fds[1]);
    ::execl("/bin/sh", "sh", "-c", ("exec " + command).c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  ::close(fds[1]);
  const std::string expected = "errors in variables:";  // the last of its start lines
  std::string output;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (output.find(expected) == std::string::npos && std::chrono::steady_clock::now() < deadline) {
    pollfd p{fds[0], POLLIN, 0};
    if (::poll(&p, 1, 200) <= 0) continue;
    char buffer[1024];
    const ssize_t got = ::read(fds[0], buffer, sizeof buffer);
    if (got <= 0) break;  // the node closed its stdout: it has ended
    output.append(buffer, static_cast<std::size_t>(got));
  }
  int status = 0;
  const bool running = ::waitpid(pid, &status, WNOHANG) == 0;
  ::kill(pid, SIGINT);
  for (int i = 0; i < 50 && ::waitpid(pid, &status, WNOHANG) == 0; ++i) ::usleep(100000);
  if (::waitpid(pid, &status, WNOHANG) == 0) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
  }
  ::close(fds[0]);
  EXPECT_NE(output.find(expected), std::string::npos) << "read from the pipe:\n" << output;
  EXPECT_TRUE(running) << "the node had ended before its start lines were read";
}

// --help answers at once, pointing at the parameters' documentation, instead of waiting for a
// master (run() gives up after 30 s).
TEST(Calibration, NodesAnswerHelpWithoutAMaster) {
  for (const std::string& node : {std::string(CALIBRATION_NODE_PATH), std::string(CORRECTION_NODE_PATH),
                                  std::string(SCALAR_SIMULATOR_PATH)}) {
    SCOPED_TRACE(node);
    const RunResult r = run("env ROS_MASTER_URI=http://localhost:1 " + node + " --help");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("docs/nodes.md"), std::string::npos) << r.output;
  }
}
