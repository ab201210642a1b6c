// Every program's command line: a usage error exits 1 (docs/programs.md), --help exits 0.
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace {

/// The programs this test suite is given (the build defines their paths).
std::vector<std::string> programs_under_test() {
  std::vector<std::string> out = {CALIBRATE_RECORDS_BIN, SIMULATE_RECORDS_BIN};
#ifdef EXPORT_CORRECTED_BIN
  out.push_back(EXPORT_CORRECTED_BIN);
#endif
#ifdef RECORDS_TO_BAG_BIN
  out.push_back(RECORDS_TO_BAG_BIN);
#endif
  return out;
}

magnetometer_insitu_calibration::test::ProgramRun run_command_line(const std::string& program, const std::string& args) {
  return magnetometer_insitu_calibration::test::run_program(program, args);
}

}  // namespace

// CLI11 ends a bad command line with its own codes (105 for a missing required option, 109 for an
// unknown one, ...); the programs exit 1 for each, and still 0 for --help.
TEST(ProgramCommandLine, UsageErrorsExit1AndHelpExits0) {
  for (const std::string& program : programs_under_test()) {
    SCOPED_TRACE(program);
    auto r = run_command_line(program, "--no-such-option 3");
    EXPECT_EQ(r.status, 1) << r.output;  // CLI11: 109 (or 106, a required option checked first)
    r = run_command_line(program, "--help");
    EXPECT_EQ(r.status, 0) << r.output;
  }
  // A required option left out; a value of the wrong type.
  auto r = run_command_line(CALIBRATE_RECORDS_BIN, "--reference a.sec");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("--test"), std::string::npos) << r.output;
  r = run_command_line(CALIBRATE_RECORDS_BIN, "--reference a.sec --test b.sec --intervals four");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("--intervals"), std::string::npos) << r.output;
}
