// rostest (with test_lemi025_driver.test, in the test_lemi025_driver binary): impossible
// parameters.
// Lemi025DriverParameters.BadParametersExitNonZero starts the driver itself with impossible
// parameters and checks the exit code and the fatal message naming the parameter.
#include "driver_process.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace {

using magnetometer_insitu_calibration::test::RunResult;
using magnetometer_insitu_calibration::test::run_driver;

TEST(Lemi025DriverParameters, BadParametersExitNonZero) {
  struct Case {
    std::string arguments, parameter;
  };
  const std::vector<Case> cases = {
      {"_source:=usb _device:=/tmp/nowhere", "parameter ~source"},
      {"_baud:=12345 _device:=/tmp/nowhere", "parameter ~baud"},
      {"_source:=serial", "parameter ~device"},  // missing device path
      {"_source:=lemibin _file:=/nonexistent/lemi.bin", "parameter ~file"},
      {"_source:=stream_file", "parameter ~file"},  // missing file
      {"_checksum:=crc16 _device:=/tmp/nowhere", "parameter ~checksum"},
      {"_field:=vertical _device:=/tmp/nowhere", "parameter ~field"},
      {"_rate:=-1 _source:=stream_file _file:=/dev/null", "parameter ~rate"},
      {"_reopen_interval:=0 _device:=/tmp/nowhere", "parameter ~reopen_interval"},
      {"_noise_nT:=-0.1 _device:=/tmp/nowhere", "parameter ~noise_nT"},
      {"_wait_for_subscribers:=-1 _source:=stream_file _file:=/dev/null", "parameter ~wait_for_subscribers"},
  };
  int index = 0;
  for (const Case& c : cases) {
    const std::string name = "bad_lemi025_driver_" + std::to_string(index++);
    const RunResult r = run_driver(name, c.arguments);
    EXPECT_EQ(r.exit_code, 1) << c.arguments << "\n" << r.output;
    EXPECT_NE(r.output.find(c.parameter), std::string::npos) << c.arguments << ": expected '" << c.parameter
                                                            << "' in:\n" << r.output;
    EXPECT_NE(r.output.find("FATAL"), std::string::npos) << r.output;
  }
}

}  // namespace
