// CSV records: fixtures with known values, round trips with UNIX and ISO time, errors that
// name file, line and column; format detection and dispatch (record_file.hpp).
#include "magnetometer_insitu_calibration/formats/csv_record.hpp"
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include "test_support.hpp"
#include "test_constants.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;
using mic::test::contains;
using mic::test::make_temp_dir;
using mic::test::package_data;
using mic::test::read_lines;
using mic::test::test_data;
using mic::test::write_bytes;

namespace {

using magnetometer_insitu_calibration::test::kNaN;
using magnetometer_insitu_calibration::test::kMay14;

/// The InputError message of reading a CSV file with `content`, or "" if it read fine.
std::string csv_error(const std::string& dir, const std::string& name, const std::string& content) {
  const std::string path = dir + "/" + name;
  write_bytes(path, content);
  try {
    mic::read_csv_record(path);
  } catch (const mic::InputError& error) {
    return error.what();
  }
  return "";
}

mic::VectorRecord sample_record(std::size_t n, double t0, double step) {
  mic::VectorRecord record;
  record.components = {"x_test", "y_test", "z_test"};
  record.values_nT.resize(static_cast<Eigen::Index>(n), 3);
  for (std::size_t i = 0; i < n; ++i) {
    record.time_s.push_back(t0 + step * static_cast<double>(i));
    record.values_nT(i, 0) = 21000.0 + 987.654321 * std::sin(0.003 * i);
    record.values_nT(i, 1) = -12.5 + 0.0004 * i;
    record.values_nT(i, 2) = 43999.9995 - 1e-3 * i;
  }
  record.values_nT(3, 1) = kNaN;
  record.values_nT(n - 1, 0) = kNaN;
  return record;
}

void expect_same(const mic::VectorRecord& back, const mic::VectorRecord& record, double tolerance) {
  ASSERT_EQ(back.size(), record.size());
  EXPECT_EQ(back.components, record.components);
  for (std::size_t i = 0; i < record.size(); ++i) {
    ASSERT_EQ(back.time_s[i], record.time_s[i]) << "sample " << i;
    for (int c = 0; c < 3; ++c) {
      if (std::isnan(record.values_nT(i, c))) {
        ASSERT_TRUE(std::isnan(back.values_nT(i, c))) << i << " " << c;
      } else {
        ASSERT_NEAR(back.values_nT(i, c), record.values_nT(i, c), tolerance) << i << " " << c;
      }
    }
  }
}

}  // namespace

TEST(ReadCsvRecord, UnixTimeFixture) {
  const mic::VectorRecord record = mic::read_csv_record(test_data("formats/csv_unix.csv"));
  ASSERT_EQ(record.size(), 4u);
  EXPECT_EQ(record.components[0], "Bx");
  EXPECT_EQ(record.components[1], "By");
  EXPECT_EQ(record.components[2], "Bz");
  EXPECT_EQ(record.time_s[0], kMay14);
  EXPECT_EQ(record.time_s[1], kMay14 + 1.25);
  EXPECT_EQ(record.time_s[3], kMay14 + 3.0);
  EXPECT_EQ(record.values_nT(0, 0), 341.93);
  EXPECT_EQ(record.values_nT(0, 2), 376.19);
  EXPECT_TRUE(std::isnan(record.values_nT(1, 1)));  // empty field
  EXPECT_TRUE(std::isnan(record.values_nT(2, 0)));  // nan
  EXPECT_TRUE(std::isnan(record.values_nT(2, 2)));  // 99999.00
  EXPECT_EQ(record.values_nT(3, 0), -150.0);        // -1.5e2
  EXPECT_EQ(record.values_nT(3, 1), 545.21);        // +545.21
  EXPECT_TRUE(std::isnan(record.values_nT(3, 2)));  // 88888
  EXPECT_EQ(record.values_nT.array().isNaN().count(), 4);
  EXPECT_EQ(record.header.at("comments"),
            "Test record: UNIX seconds, nT\nsecond comment line\ninterleaved comment");
  EXPECT_EQ(record.source, test_data("formats/csv_unix.csv"));
}

TEST(ReadCsvRecord, IsoTimeSemicolonsQuotesAndCrlf) {
  const mic::VectorRecord record = mic::read_csv_record(test_data("formats/csv_iso_semicolon.csv"));
  ASSERT_EQ(record.size(), 3u);
  EXPECT_EQ(record.components[0], "x");
  EXPECT_EQ(record.components[2], "z");
  EXPECT_EQ(record.time_s[0], kMay14);
  EXPECT_EQ(record.time_s[1], kMay14 + 0.5);
  EXPECT_EQ(record.time_s[2], kMay14 + 1.25);
  EXPECT_EQ(record.values_nT(0, 0), 1.5);
  EXPECT_TRUE(std::isnan(record.values_nT(1, 2)));
  EXPECT_EQ(record.values_nT(2, 0), 7.0);  // " 7 " trimmed
  EXPECT_EQ(record.values_nT(2, 2), 9.0);
  EXPECT_EQ(record.header.count("comments"), 0u);
}

TEST(ReadCsvRecord, TabsWithoutHeaderGiveDefaultNamesAndBomIsIgnored) {
  const std::string path = make_temp_dir("csv_tab") + "/tab.tsv";
  write_bytes(path, "\xEF\xBB\xBF" "10\t1\t2\t3\n20.5\t4\t\t6\n");  // with a UTF-8 BOM
  const mic::VectorRecord record = mic::read_csv_record(path);
  ASSERT_EQ(record.size(), 2u);
  EXPECT_EQ(record.components[0], "X");
  EXPECT_EQ(record.components[1], "Y");
  EXPECT_EQ(record.components[2], "Z");
  EXPECT_EQ(record.time_s[0], 10.0);
  EXPECT_EQ(record.time_s[1], 20.5);
  EXPECT_EQ(record.values_nT(1, 2), 6.0);
  EXPECT_TRUE(std::isnan(record.values_nT(1, 1)));
}

TEST(ReadCsvRecord, ErrorsNameFileLineAndColumn) {
  const std::string dir = make_temp_dir("csv_errors");
  const std::string head = "# comment\ntime,Bx,By,Bz\n";  // data from line 3

  std::string message = csv_error(dir, "bad_number.csv", head + "1,2,3,4\n\n2,5,6x,7\n");
  EXPECT_TRUE(contains(message, "bad_number.csv:5: column 3 (By): '6x' is not a number"))
      << message;

  message = csv_error(dir, "backwards.csv", head + "1,2,3,4\n2,2,3,4\n1.5,2,3,4\n");
  EXPECT_TRUE(contains(message, "backwards.csv:5: column 1 (time): time goes backwards"))
      << message;
  EXPECT_TRUE(contains(message, "on line 4")) << message;

  message = csv_error(dir, "duplicate.csv", head + "1,2,3,4\n1,2,3,4\n");
  EXPECT_TRUE(contains(message, "duplicate.csv:4: column 1 (time): duplicate time")) << message;

  message = csv_error(dir, "short.csv", head + "1,2,3,4\n2,3,4\n");
  EXPECT_TRUE(contains(message, "short.csv:4: expected 4 columns (time,Bx,By,Bz), found 3"))
      << message;

  message = csv_error(dir, "long.csv", head + "1,2,3,4,\n");
  EXPECT_TRUE(contains(message, "long.csv:3: expected 4 columns")) << message;

  message = csv_error(dir, "bad_time.csv", head + "2025-05-14T00:00:00Z,1,2,3\n2025-05-14T00:61:00Z,1,2,3\n");
  EXPECT_TRUE(contains(message, "bad_time.csv:4: column 1 (time): '2025-05-14T00:61:00Z' is neither"))
      << message;

  message = csv_error(dir, "bad_first_time.csv", "yesterday,1,2,3\n");  // not taken for a header
  EXPECT_TRUE(contains(message, "bad_first_time.csv:1: column 1 (time)")) << message;

  message = csv_error(dir, "inf.csv", "1,2,inf,4\n");
  EXPECT_TRUE(contains(message, "inf.csv:1: column 3 (Y): 'inf' is not a number")) << message;

  message = csv_error(dir, "empty.csv", head + "\n# only comments\n");
  EXPECT_TRUE(contains(message, "empty.csv: no data lines")) << message;

  message = csv_error(dir, "nothing.csv", "");
  EXPECT_TRUE(contains(message, "nothing.csv: no data lines")) << message;

  try {
    mic::read_csv_record(dir + "/missing.csv");
    ADD_FAILURE() << "missing file read";
  } catch (const mic::InputError& error) {
    EXPECT_TRUE(contains(error.what(), "missing.csv: cannot open: No such file or directory"))
        << error.what();
  }
}

TEST(WriteCsvRecord, UnixTimeRoundTripIsExact) {
  // Irregular times that are not on any decimal grid.
  mic::VectorRecord record = sample_record(2000, kMay14 + 0.123456789, 0.0999999937);
  const std::string dir = make_temp_dir("csv_unix_rt");
  mic::write_csv_record(dir + "/unix.csv", record, false, 6);
  expect_same(mic::read_csv_record(dir + "/unix.csv"), record, 0.5e-6 + 1e-9);
  mic::write_csv_record(dir + "/unix.csv.gz", record, false, 3);
  expect_same(mic::read_csv_record(dir + "/unix.csv.gz"), record, 0.5e-3 + 1e-9);
  const std::vector<std::string> lines = read_lines(dir + "/unix.csv");
  EXPECT_EQ(lines[0], "time,x_test,y_test,z_test");
  // Sample 3 (y missing): shortest exact time, values to 6 decimals (truth from Python).
  EXPECT_EQ(lines[4], "1747180800.4234567,21008.888769,nan,43999.996500");
}

TEST(WriteCsvRecord, IsoTimeRoundTripUsesFewestExactDecimals) {
  const std::string dir = make_temp_dir("csv_iso_rt");
  // Whole seconds: 3 decimals.
  mic::VectorRecord seconds = sample_record(500, kMay14 - 250.0, 1.0);
  seconds.header["comments"] = "written by a test\nsecond line";
  mic::write_csv_record(dir + "/s.csv", seconds);  // iso_time, 3 decimals by default
  std::vector<std::string> lines = read_lines(dir + "/s.csv");
  EXPECT_EQ(lines[0], "# written by a test");
  EXPECT_EQ(lines[1], "# second line");
  EXPECT_EQ(lines[2], "time,x_test,y_test,z_test");
  EXPECT_EQ(lines[3].substr(0, 25), "2025-05-13T23:55:50.000Z,");
  const mic::VectorRecord back = mic::read_csv_record(dir + "/s.csv");
  expect_same(back, seconds, 0.5e-3 + 1e-9);
  EXPECT_EQ(back.header.at("comments"), "written by a test\nsecond line");

  // 0.25 ms steps: 6 decimals.
  const mic::VectorRecord sub_ms = sample_record(300, kMay14, 0.00025);
  mic::write_csv_record(dir + "/us.csv", sub_ms, true, 4);
  lines = read_lines(dir + "/us.csv");
  EXPECT_EQ(lines[2].substr(0, 28), "2025-05-14T00:00:00.000250Z,");
  expect_same(mic::read_csv_record(dir + "/us.csv"), sub_ms, 0.5e-4 + 1e-9);

  // Off every grid: 9 decimals, still exact for times near 2025 (1 ulp is 0.24 us).
  const mic::VectorRecord odd = sample_record(300, kMay14 + 0.123456789, 0.0999999937);
  mic::write_csv_record(dir + "/ns.csv", odd);
  lines = read_lines(dir + "/ns.csv");
  EXPECT_EQ(lines[1].substr(0, 31), "2025-05-14T00:00:00.123456717Z,");  // the double's digits
  expect_same(mic::read_csv_record(dir + "/ns.csv"), odd, 0.5e-3 + 1e-9);
}

TEST(WriteCsvRecord, RefusesWhatCannotBeReadBack) {
  const std::string dir = make_temp_dir("csv_refuse");
  auto message_of = [&](const mic::VectorRecord& record) {
    try {
      mic::write_csv_record(dir + "/refused.csv", record);
    } catch (const mic::InputError& error) {
      return std::string(error.what());
    }
    return std::string();
  };
  mic::VectorRecord bad = sample_record(5, kMay14, 1.0);
  bad.values_nT(2, 2) = 88887.9996;  // prints as 88888.000
  EXPECT_TRUE(contains(message_of(bad), "refused.csv: sample 2, component z_test"));
  bad = sample_record(5, kMay14, 1.0);
  bad.time_s[3] = bad.time_s[2];
  EXPECT_TRUE(contains(message_of(bad), "refused.csv: sample 3: time"));
  bad = sample_record(5, kMay14, 1.0);
  bad.components[1] = "a,b";
  EXPECT_TRUE(contains(message_of(bad), "component name 'a,b'"));
  bad.components[1] = "42";  // would make the header line look like data
  EXPECT_TRUE(contains(message_of(bad), "component name '42'"));
  EXPECT_TRUE(contains(message_of(mic::VectorRecord()), "empty record"));
  std::ifstream refused(dir + "/refused.csv");
  EXPECT_FALSE(refused.good());  // nothing was created
}

TEST(RecordFile, DetectsFormatByContentAndDispatches) {
  EXPECT_EQ(mic::detect_record_format(package_data("wic20250514_lemi036.sec.gz")),
            mic::RecordFormat::kIaga2002);
  EXPECT_EQ(mic::detect_record_format(test_data("formats/iaga_small.sec")),
            mic::RecordFormat::kIaga2002);
  EXPECT_EQ(mic::detect_record_format(test_data("formats/csv_unix.csv")), mic::RecordFormat::kCsv);
  EXPECT_EQ(mic::detect_record_format(test_data("formats/csv_iso_semicolon.csv")),
            mic::RecordFormat::kCsv);
  EXPECT_STREQ(mic::record_format_name(mic::RecordFormat::kIaga2002), "IAGA-2002");
  EXPECT_STREQ(mic::record_format_name(mic::RecordFormat::kCsv), "CSV");

  const mic::VectorRecord iaga = mic::read_record(test_data("formats/iaga_small.sec"));
  EXPECT_EQ(iaga.station, "WIC");
  EXPECT_EQ(iaga.size(), 5u);
  const mic::VectorRecord csv = mic::read_record(test_data("formats/csv_unix.csv"));
  EXPECT_EQ(csv.components[0], "Bx");
  EXPECT_EQ(csv.size(), 4u);

  // A gzip-compressed CSV written by write_csv_record is detected and read too.
  const std::string path = make_temp_dir("record_file") + "/r.csv.gz";
  mic::write_csv_record(path, csv, false);
  EXPECT_EQ(mic::detect_record_format(path), mic::RecordFormat::kCsv);
  EXPECT_EQ(mic::read_record(path).time_s, csv.time_s);

  try {
    mic::read_record(test_data("formats/nowhere.csv"));
    ADD_FAILURE() << "missing file read";
  } catch (const mic::InputError& error) {
    EXPECT_TRUE(contains(error.what(), "nowhere.csv: cannot open")) << error.what();
  }
  // A rosbag (its version line, then binary records) is named as one, not failed on as a CSV.
  const std::string bag = make_temp_dir("record_file") + "/pair.bag";
  {
    std::ofstream out(bag, std::ios::binary);
    out << "#ROSBAG V2.0\n" << std::string("\x04\x00\x00\x00op=\x03", 9);
  }
  try {
    mic::read_record(bag);
    ADD_FAILURE() << "a rosbag read as a record file";
  } catch (const mic::InputError& error) {
    EXPECT_TRUE(contains(error.what(), "pair.bag: is a rosbag: its records are read by topic (calibrate_records --bag"))
        << error.what();
  }
}

// A CSV still being written, cut within its last line (no line end): that line is dropped and
// noted, with its auxiliary columns; with a line end it refuses the file, naming line and column.
TEST(ReadCsvRecord, AFileStillBeingWrittenLosesOnlyItsCutLastLine) {
  const std::string dir = make_temp_dir("csv_partial");
  const std::string body = "time,x,y,z,temperature\n1747180800,1,2,3,20.5\n1747180801,1,2,3,20.6\n1747180802,1,";
  {
    std::ofstream out(dir + "/cut.csv", std::ios::binary);
    out << body;
  }
  const mic::VectorRecord r = mic::read_csv_record(dir + "/cut.csv");
  ASSERT_EQ(r.size(), 2u);
  ASSERT_EQ(r.auxiliary.size(), 1u);
  EXPECT_EQ(r.auxiliary[0].values.size(), 2u);
  ASSERT_EQ(r.header.count(mic::kPartialLastLineKey), 1u);
  EXPECT_TRUE(contains(r.header.at(mic::kPartialLastLineKey), "cut.csv:4: last line dropped")) << r.header.at(mic::kPartialLastLineKey);
  {
    std::ofstream out(dir + "/cut_ended.csv", std::ios::binary);
    out << body << "\n";
  }
  try {
    mic::read_csv_record(dir + "/cut_ended.csv");
    ADD_FAILURE() << "a short line with its line end was read";
  } catch (const mic::InputError& error) {
    EXPECT_TRUE(contains(error.what(), "cut_ended.csv:4: expected 5 columns")) << error.what();
  }
}

// The same rule as IAGA-2002's: a CSV's last line cut within its last value (20.6 for 20.65)
// parses; without a line end, shorter than the line before and with fewer decimals, it is dropped
// and read_record warns, naming file and line. A complete last line without a line end is kept.
TEST(ReadCsvRecord, ALastLineCutWithinItsLastValueIsDroppedWithAWarning) {
  const std::string dir = make_temp_dir("csv_cut_value");
  const std::string body = "time,x,y,z,temperature\n1747180800,1,2,3,20.55\n1747180801,1,2,3,20.65";
  write_bytes(dir + "/complete.csv", body);
  write_bytes(dir + "/cut.csv", body.substr(0, body.size() - 1));
  std::vector<std::string> warnings;
  EXPECT_EQ(mic::read_record(dir + "/complete.csv", mic::LemiReadOptions(), &warnings).size(), 2u);
  EXPECT_TRUE(warnings.empty()) << warnings.front();
  const mic::VectorRecord r = mic::read_record(dir + "/cut.csv", mic::LemiReadOptions(), &warnings);
  ASSERT_EQ(r.size(), 1u);
  ASSERT_EQ(r.auxiliary.size(), 1u);
  EXPECT_EQ(r.auxiliary[0].values, std::vector<double>{20.55});
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], dir + "/cut.csv:3: last line dropped (the lines before it are kept): it ends the file "
                               "without a line end (a file still being written?) and is cut short: 21 characters, "
                               "its last field 1 decimals, where the line before has 22 and 2")
      << warnings[0];
}

// Auxiliary columns (e.g. the sensor temperature beside the field, INTERMAGNET's 1-second
// standard): named by the header, read into record.auxiliary; refused without a header.
TEST(ReadCsvRecord, TemperatureColumnBecomesAnAuxiliaryChannel) {
  const std::string dir = make_temp_dir("csv_aux");
  const std::string path = dir + "/with_temperature.csv";
  write_bytes(path, "time,X,Y,Z,Temperature_sensor,t2\n10,1,2,3,21.25,\n11,4,5,6,nan,7.5\n12,7,8,9,-3,8\n");
  const mic::VectorRecord record = mic::read_csv_record(path);
  ASSERT_EQ(record.size(), 3u);
  EXPECT_EQ(record.values_nT(2, 2), 9.0);
  ASSERT_EQ(record.auxiliary.size(), 2u);
  EXPECT_EQ(record.auxiliary[0].name, "Temperature_sensor");
  EXPECT_EQ(record.auxiliary[0].unit, "degC");
  EXPECT_EQ(record.auxiliary[1].name, "t2");
  EXPECT_EQ(record.auxiliary[1].unit, "");
  ASSERT_EQ(record.auxiliary[0].values.size(), 3u);
  EXPECT_EQ(record.auxiliary[0].values[0], 21.25);
  EXPECT_TRUE(std::isnan(record.auxiliary[0].values[1]));
  EXPECT_EQ(record.auxiliary[0].values[2], -3.0);
  EXPECT_TRUE(std::isnan(record.auxiliary[1].values[0]));
  EXPECT_EQ(record.auxiliary[1].values[2], 8.0);
}

TEST(ReadCsvRecord, BadAuxiliaryColumnsNameLineAndColumn) {
  const std::string dir = make_temp_dir("csv_aux_errors");
  std::string message = csv_error(dir, "text.csv", "time,X,Y,Z,temperature\n1,2,3,4,20.5\n2,2,3,4,warm\n");
  EXPECT_TRUE(contains(message, "text.csv:3: column 5 (temperature): 'warm' is not a number")) << message;

  message = csv_error(dir, "no_header.csv", "1,2,3,4,20.5\n");
  EXPECT_TRUE(contains(message, "no_header.csv:1: expected 4 columns (time,X,Y,Z), found 5")) << message;
  EXPECT_TRUE(contains(message, "need a header line naming them")) << message;

  message = csv_error(dir, "missing_value_column.csv", "time,X,Y,Z,temperature\n1,2,3,4,20\n2,2,3,4\n");
  EXPECT_TRUE(contains(message, "missing_value_column.csv:3: expected 5 columns (time,X,Y,Z,temperature), found 4"))
      << message;

  message = csv_error(dir, "repeated.csv", "time,X,Y,Z,t,t\n1,2,3,4,5,6\n");
  EXPECT_TRUE(contains(message, "repeated.csv:1: header: column name 't' repeated")) << message;

  message = csv_error(dir, "infinite.csv", "time,X,Y,Z,temperature\n1,2,3,4,inf\n");
  EXPECT_TRUE(contains(message, "infinite.csv:2: column 5 (temperature): 'inf' is not a number")) << message;
}

TEST(WriteCsvRecord, AuxiliaryChannelsRoundTrip) {
  const std::string dir = make_temp_dir("csv_aux_write");
  mic::VectorRecord record = sample_record(50, kMay14, 1.0);
  mic::AuxiliaryChannel temperature{"temperature", "", "degC", {}};
  for (std::size_t i = 0; i < record.size(); ++i) temperature.values.push_back(18.0 + 0.0137 * i);
  temperature.values[7] = kNaN;
  record.auxiliary.push_back(temperature);
  const std::string path = dir + "/aux.csv";
  mic::write_csv_record(path, record);
  const mic::VectorRecord back = mic::read_csv_record(path);
  expect_same(back, record, 0.0011);
  ASSERT_EQ(back.auxiliary.size(), 1u);
  EXPECT_EQ(back.auxiliary[0].unit, "degC");
  for (std::size_t i = 0; i < record.size(); ++i) {
    if (i == 7) {
      EXPECT_TRUE(std::isnan(back.auxiliary[0].values[i]));
    } else {
      EXPECT_EQ(back.auxiliary[0].values[i], temperature.values[i]) << i;  // shortest exact form
    }
  }
  record.auxiliary[0].values.pop_back();
  try {
    mic::write_csv_record(dir + "/short_aux.csv", record);
    ADD_FAILURE() << "a channel of the wrong length was written";
  } catch (const mic::InputError& error) {
    EXPECT_TRUE(contains(error.what(), "auxiliary channel temperature has 49 values for 50 samples")) << error.what();
  }
}
