// A record still being written, cut within its last line: every program that reads it drops that
// line and prints the readers' warning the same way, "<program>: warning: <file>:<line>: ...".
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <string>

namespace {

magnetometer_insitu_calibration::test::ProgramRun run_reader(const std::string& program, const std::string& args) {
  return magnetometer_insitu_calibration::test::run_program(program, args);
}

std::string whole_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace

TEST(ProgramsOnACutLastLine, EachDropsItAndWarnsNamingFileAndLine) {
  namespace mic = magnetometer_insitu_calibration;
  const std::string dir = mic::test::make_temp_dir("cut_last_line");
  mic::SimulationSettings s;
  s.duration_s = 6 * 3600.0;
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::write_iaga2002(dir + "/reference.sec", pair.reference, mic::Iaga2002WriteOptions());
  mic::write_iaga2002(dir + "/test.sec", pair.test, mic::Iaga2002WriteOptions());
  std::string text = whole_file(dir + "/test.sec");
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
  text.pop_back();  // the last line without its last digit and line end: a file still being written
  mic::test::write_bytes(dir + "/cut.sec", text);
  const std::string line = std::to_string(std::count(text.begin(), text.end(), '\n') + 1);
  const std::string warning = ": warning: " + dir + "/cut.sec:" + line +
                              ": last line dropped (the lines before it are kept): it ends the file without a line "
                              "end (a file still being written?) and is cut short";

  mic::test::ProgramRun r = run_reader(CALIBRATE_RECORDS_BIN, "--reference " + dir + "/reference.sec --test " + dir +
                                                                  "/cut.sec --intervals 2 --json " + dir + "/report.json");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("calibrate_records" + warning), std::string::npos) << r.output;
#ifdef EXPORT_CORRECTED_BIN
  r = run_reader(EXPORT_CORRECTED_BIN, "--test " + dir + "/cut.sec --calibration " + dir + "/report.json -o " + dir +
                                           "/corrected.sec");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("export_corrected" + warning), std::string::npos) << r.output;
#endif
#ifdef RECORDS_TO_BAG_BIN
  r = run_reader(RECORDS_TO_BAG_BIN, "--quiet --reference " + dir + "/reference.sec --test " + dir + "/cut.sec -o " +
                                         dir + "/pair.bag");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("records_to_bag" + warning), std::string::npos) << r.output;
#endif
}
