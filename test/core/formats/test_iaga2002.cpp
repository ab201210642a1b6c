// IAGA-2002: the real WIC LEMI-036 day (data/wic20250514_lemi036.sec.gz), small fixtures in
// test/data/formats with known values and known bad lines, and write/read round trips.
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "magnetometer_insitu_calibration/formats/record_join.hpp"
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include "test_support.hpp"
#include "test_constants.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
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

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// The InputError message of reading `path`, or "" if it read without error.
std::string iaga_read_error(const std::string& path) {
  try {
    mic::read_iaga2002(path);
  } catch (const mic::InputError& error) {
    return error.what();
  }
  return "";
}

/// Every line exactly 70 characters followed by CRLF, no bare CR or LF anywhere.
void expect_iaga_layout(const std::string& bytes) {
  ASSERT_GE(bytes.size(), 2u);
  ASSERT_EQ(bytes.substr(bytes.size() - 2), "\r\n");
  std::size_t start = 0;
  std::size_t line = 1;
  while (start < bytes.size()) {
    const std::size_t end = bytes.find("\r\n", start);
    ASSERT_NE(end, std::string::npos);
    const std::string text = bytes.substr(start, end - start);
    ASSERT_EQ(text.size(), 70u) << "line " << line << ": '" << text << "'";
    ASSERT_EQ(text.find_first_of("\r\n"), std::string::npos) << "line " << line;
    start = end + 2;
    ++line;
  }
}

}  // namespace

TEST(ReadIaga2002, RealWicLemi036Day) {
  const mic::VectorRecord record = mic::read_iaga2002(package_data("wic20250514_lemi036.sec.gz"));
  ASSERT_EQ(record.size(), 86400u);
  ASSERT_EQ(record.values_nT.rows(), 86400);
  EXPECT_EQ(record.time_s.front(), kMay14);
  EXPECT_EQ(mic::format_iso8601(record.time_s.front()), "2025-05-14T00:00:00.000Z");
  EXPECT_EQ(record.time_s.back(), kMay14 + 86399.0);
  for (std::size_t i = 0; i < record.size(); ++i) {
    ASSERT_EQ(record.time_s[i], kMay14 + static_cast<double>(i)) << i;
  }
  // First and last data lines of the file:
  // 2025-05-14 00:00:00.000 134       341.93    545.24    376.19  88888.00
  // 2025-05-14 23:59:59.000 134       321.04    521.07    380.69  88888.00
  EXPECT_EQ(record.values_nT(0, 0), 341.93);
  EXPECT_EQ(record.values_nT(0, 1), 545.24);
  EXPECT_EQ(record.values_nT(0, 2), 376.19);
  EXPECT_EQ(record.values_nT(86399, 0), 321.04);
  EXPECT_EQ(record.values_nT(86399, 1), 521.07);
  EXPECT_EQ(record.values_nT(86399, 2), 380.69);
  EXPECT_EQ(record.values_nT(86398, 0), 321.03);  // 23:59:58
  EXPECT_EQ(record.values_nT(86398, 2), 380.70);
  EXPECT_FALSE(record.values_nT.hasNaN());
  EXPECT_EQ(record.components[0], "H");
  EXPECT_EQ(record.components[1], "E");
  EXPECT_EQ(record.components[2], "Z");
  EXPECT_EQ(record.station, "WIC");
  EXPECT_EQ(record.source, package_data("wic20250514_lemi036.sec.gz"));
  EXPECT_EQ(record.header.at("Format"), "IAGA-2002");
  EXPECT_EQ(record.header.at("Source of Data"), "Conrad Observatory, GeoSphere Austria");
  EXPECT_EQ(record.header.at("Station Name"), "Conrad Observatory");
  EXPECT_EQ(record.header.at("IAGA Code"), "WIC");
  EXPECT_EQ(record.header.at("Geodetic Latitude"), "47.930");
  EXPECT_EQ(record.header.at("Geodetic Longitude"), "15.865");
  EXPECT_EQ(record.header.at("Elevation"), "1089");
  EXPECT_EQ(record.header.at("Reported"), "HEZF");
  EXPECT_EQ(record.header.at("Sensor Orientation"), "HDZ");
  EXPECT_EQ(record.header.at("Digital Sampling"), "0.1 second");
  EXPECT_EQ(record.header.at("Data Interval Type"), "1-second");
  EXPECT_EQ(record.header.at("Data Type"), "variation");
  EXPECT_EQ(record.header.at("comments"),
            "LEMI036 #1 (pier GS-O-63, borehole) raw variations (nT),\n"
            "compensation field removed.\n"
            "Licence CC-BY-4.0: Earth observation data from the Conrad\n"
            "Observatory,\n"
            "GeoSphere Austria (www.conrad-observatory.at). Noise <10\n"
            "pT/sqrt(Hz).");
  EXPECT_EQ(record.header.size(), 13u);
}

TEST(ReadIaga2002, SmallFixtureSentinelsAndFractionalTime) {
  const mic::VectorRecord record = mic::read_iaga2002(test_data("formats/iaga_small.sec"));
  ASSERT_EQ(record.size(), 5u);
  EXPECT_EQ(record.time_s[2], kMay14 + 2.0);
  EXPECT_EQ(record.time_s[4], kMay14 + 4.5);  // 00:00:04.500
  EXPECT_EQ(record.values_nT(1, 0), 341.96);
  EXPECT_TRUE(std::isnan(record.values_nT(2, 0)));  // 99999.00 missing
  EXPECT_EQ(record.values_nT(2, 1), 545.22);
  EXPECT_EQ(record.values_nT(3, 1), -545.21);
  EXPECT_TRUE(std::isnan(record.values_nT(3, 2)));  // 90000.00 >= 88888
  EXPECT_EQ(record.values_nT(4, 2), 376.20);
  EXPECT_EQ((record.values_nT.array().isNaN()).count(), 2);
  EXPECT_EQ(record.header.at("comments"),
            "Small test file cut from wic20250514_lemi036.sec: H missing\n"
            "(99999.00) at 00:00:02, Z above 88888 at 00:00:03.");
}

TEST(ReadIaga2002, ErrorsNameFileLineAndField) {
  std::string message = iaga_read_error(test_data("formats/iaga_bad_number.sec"));
  EXPECT_TRUE(contains(message, "iaga_bad_number.sec:18: ")) << message;
  EXPECT_TRUE(contains(message, "WICE")) << message;
  EXPECT_TRUE(contains(message, "54x.22")) << message;

  message = iaga_read_error(test_data("formats/iaga_backwards.sec"));
  EXPECT_TRUE(contains(message, "iaga_backwards.sec:19: ")) << message;
  EXPECT_TRUE(contains(message, "backwards")) << message;
  EXPECT_TRUE(contains(message, "2025-05-14T00:00:01.500Z")) << message;
  EXPECT_TRUE(contains(message, "on line 18")) << message;  // the previous record

  message = iaga_read_error(test_data("formats/iaga_duplicate.sec"));
  EXPECT_TRUE(contains(message, "iaga_duplicate.sec:17: ")) << message;
  EXPECT_TRUE(contains(message, "duplicate time")) << message;

  message = iaga_read_error(test_data("formats/iaga_short_line.sec"));
  EXPECT_TRUE(contains(message, "iaga_short_line.sec:20: ")) << message;
  EXPECT_TRUE(contains(message, "too few columns: expected 7")) << message;
  EXPECT_TRUE(contains(message, "found 6")) << message;

  message = iaga_read_error(test_data("formats/iaga_bad_date.sec"));
  EXPECT_TRUE(contains(message, "iaga_bad_date.sec:17: ")) << message;
  EXPECT_TRUE(contains(message, "DATE/TIME")) << message;
  EXPECT_TRUE(contains(message, "2025-02-30")) << message;

  message = iaga_read_error(test_data("formats/iaga_no_data.sec"));
  EXPECT_TRUE(contains(message, "iaga_no_data.sec: no data lines")) << message;

  message = iaga_read_error(test_data("formats/no_such_file.sec"));
  EXPECT_TRUE(contains(message, "no_such_file.sec: cannot open: No such file or directory"))
      << message;
}

TEST(ReadIaga2002, ErrorsFromEditedFixture) {
  const std::string dir = make_temp_dir("iaga_edit");
  const std::string good = read_bytes(test_data("formats/iaga_small.sec"));
  struct Case {
    std::string from, to, expect;
  };
  const Case cases[] = {
      // line 17: day of year that does not match the date
      {"2025-05-14 00:00:01.000 134", "2025-05-14 00:00:01.000 135", ":17: DOY field: 135"},
      // line 16: an extra column
      {"376.19  88888.00\r\n2025-05-14 00:00:01", "376.19  88888.00 1\r\n2025-05-14 00:00:01",
       ":16: too many columns"},
      // line 15: column header without DOY
      {"TIME         DOY", "TIME         ABC", ":15: column header"},
      // line 2: a header record without the leading space
      {" Source of Data", "XSource of Data", ":2: expected a header record"},
      // line 19: an infinite value
      {"   -545.21", "  -inf    ", ":19: WICE field: '-inf'"},
  };
  for (const Case& c : cases) {
    const std::size_t at = good.find(c.from);
    ASSERT_NE(at, std::string::npos) << c.from;
    std::string edited = good;
    edited.replace(at, c.from.size(), c.to);
    const std::string path = dir + "/edited.sec";
    write_bytes(path, edited);
    const std::string message = iaga_read_error(path);
    EXPECT_TRUE(contains(message, "edited.sec" + c.expect)) << message;
  }
  // No column header at all.
  write_bytes(dir + "/header_only.sec", good.substr(0, good.find("DATE")));
  EXPECT_TRUE(contains(iaga_read_error(dir + "/header_only.sec"), "header_only.sec: no column header"));
}

// A daily file still being written ends within a record, without a line end: that last line is
// dropped and noted (read_records warns), the record before it kept. The same line with its line
// end, or a damaged line before the last, still refuses the file.
TEST(ReadIaga2002, AFileStillBeingWrittenLosesOnlyItsCutLastLine) {
  const std::string dir = make_temp_dir("iaga_partial");
  std::string good = read_bytes(test_data("formats/iaga_small.sec"));
  while (good.size() >= 2 && good.compare(good.size() - 2, 2, "\r\n") == 0) good.resize(good.size() - 2);
  const std::size_t last = good.rfind("\r\n") + 2;  // the last data line
  const std::string cut = good.substr(0, last + 40);  // within its first value
  write_bytes(dir + "/cut.sec", cut);
  const mic::VectorRecord full = mic::read_iaga2002(test_data("formats/iaga_small.sec"));
  const mic::VectorRecord partial = mic::read_iaga2002(dir + "/cut.sec");
  ASSERT_EQ(partial.size() + 1, full.size());
  EXPECT_EQ(partial.time_s, std::vector<double>(full.time_s.begin(), full.time_s.end() - 1));
  for (Eigen::Index i = 0; i < partial.values_nT.rows(); ++i)
    for (int c = 0; c < 3; ++c) {
      const double a = partial.values_nT(i, c), b = full.values_nT(i, c);  // the sentinels NaN in both
      EXPECT_TRUE(a == b || (std::isnan(a) && std::isnan(b))) << i << " " << c;
    }
  ASSERT_EQ(partial.header.count(mic::kPartialLastLineKey), 1u);
  EXPECT_TRUE(contains(partial.header.at(mic::kPartialLastLineKey),
                       "cut.sec:20: last line dropped (the lines before it are kept): it ends the file without a "
                       "line end (a file still being written?) and does not parse: too few columns"))
      << partial.header.at(mic::kPartialLastLineKey);
  std::vector<std::string> warnings;
  EXPECT_EQ(mic::read_records({dir + "/cut.sec"}, &warnings).size(), partial.size());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_TRUE(contains(warnings[0], "cut.sec:20: last line dropped")) << warnings[0];

  write_bytes(dir + "/cut_ended.sec", cut + "\r\n");
  EXPECT_TRUE(contains(iaga_read_error(dir + "/cut_ended.sec"), "cut_ended.sec:20: too few columns"));
  std::string middle = good;
  middle.erase(last - 30, 20);  // the line before the last damaged
  write_bytes(dir + "/middle.sec", middle + "\r\n");
  EXPECT_TRUE(contains(iaga_read_error(dir + "/middle.sec"), "middle.sec:19:"));
}

// A last line cut within its last value parses, to a wrong value (48123.4 for 48123.45): shorter
// than the line before and with fewer decimals, it is dropped as a line that does not parse is,
// and read_record (what every program reads through) passes the warning on, naming file and line.
// Complete, its line end missing or not, the same line is kept without a warning.
TEST(ReadIaga2002, ALastLineCutWithinItsLastValueIsDroppedWithAWarning) {
  const std::string dir = make_temp_dir("iaga_cut_value");
  std::string good = read_bytes(test_data("formats/iaga_small.sec"));
  while (good.size() >= 2 && good.compare(good.size() - 2, 2, "\r\n") == 0) good.resize(good.size() - 2);
  ASSERT_EQ(good.compare(good.size() - 8, 8, "88888.00"), 0);
  good.replace(good.size() - 8, 8, "48123.45");  // a real F in the last line
  write_bytes(dir + "/complete.sec", good);
  write_bytes(dir + "/cut.sec", good.substr(0, good.size() - 1));
  std::vector<std::string> warnings;
  const mic::VectorRecord full = mic::read_record(dir + "/complete.sec", mic::LemiReadOptions(), &warnings);
  EXPECT_TRUE(warnings.empty()) << warnings.front();
  EXPECT_EQ(full.header.count(mic::kPartialLastLineKey), 0u);
  ASSERT_EQ(full.auxiliary.size(), 1u);
  EXPECT_EQ(full.auxiliary[0].values.back(), 48123.45);

  const mic::VectorRecord cut = mic::read_record(dir + "/cut.sec", mic::LemiReadOptions(), &warnings);
  ASSERT_EQ(cut.size() + 1, full.size());
  EXPECT_EQ(cut.time_s, std::vector<double>(full.time_s.begin(), full.time_s.end() - 1));
  EXPECT_TRUE(cut.auxiliary.empty());  // nothing of the cut F kept: the other lines' F are all missing
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], dir + "/cut.sec:20: last line dropped (the lines before it are kept): it ends the file "
                               "without a line end (a file still being written?) and is cut short: 69 characters, "
                               "its last field 1 decimals, where the line before has 70 and 2")
      << warnings[0];
}

TEST(WriteIaga2002, RewritingTheRealFileReproducesItByteForByte) {
  const mic::VectorRecord record = mic::read_iaga2002(package_data("wic20250514_lemi036.sec.gz"));
  mic::Iaga2002WriteOptions options;  // header values come from record.header
  std::istringstream comments(record.header.at("comments"));
  for (std::string line; std::getline(comments, line);) options.comments.push_back(line);
  const std::string path = make_temp_dir("iaga_rewrite") + "/wic20250514_lemi036.sec";
  mic::write_iaga2002(path, record, options);

  const std::string written = read_bytes(path);
  expect_iaga_layout(written);
  EXPECT_EQ(written.size(), 86419u * 72u);
  // The original, decompressed, with its CRLF line ends.
  std::string original;
  for (const std::string& line : read_lines(package_data("wic20250514_lemi036.sec.gz"))) {
    original += line + "\r\n";
  }
  ASSERT_EQ(original.size(), written.size());
  EXPECT_TRUE(original == written) << "first difference at byte "
                                   << std::mismatch(original.begin(), original.end(),
                                                    written.begin()).first - original.begin();
}

TEST(WriteIaga2002, RoundTripWithGapsIsExactInTimeAndTo5pTInValue) {
  mic::VectorRecord record;
  record.station = "TST";
  record.components = {"X", "Y", "Z"};
  const std::size_t n = 3000;
  record.values_nT.resize(n, 3);
  for (std::size_t i = 0; i < n; ++i) {
    record.time_s.push_back(kMay14 - 1500.0 + 0.1 * static_cast<double>(i));  // crosses midnight
    record.values_nT(i, 0) = 20000.0 + 1234.567 * std::sin(0.01 * i);
    record.values_nT(i, 1) = -150.0 + 33.3333 * std::cos(0.02 * i);
    record.values_nT(i, 2) = 44000.004 - 0.001 * i;
  }
  record.values_nT(7, 0) = kNaN;
  record.values_nT(2999, 2) = kNaN;
  for (std::size_t i = 100; i < 200; ++i) record.values_nT(i, 1) = kNaN;

  const std::string dir = make_temp_dir("iaga_roundtrip");
  for (const std::string name : {"tst.sec", "tst.sec.gz"}) {
    const std::string path = dir + "/" + name;
    mic::write_iaga2002(path, record);
    const mic::VectorRecord back = mic::read_iaga2002(path);
    ASSERT_EQ(back.size(), n);
    EXPECT_EQ(back.station, "TST");
    EXPECT_EQ(back.components[0], "X");
    EXPECT_EQ(back.components[2], "Z");
    EXPECT_EQ(back.header.at("Data Interval Type"), "0.1-second");
    EXPECT_EQ(back.header.at("Reported"), "XYZF");
    EXPECT_EQ(back.header.at("Data Type"), "variation");
    for (std::size_t i = 0; i < n; ++i) {
      // 0.1 * i times are not on the millisecond grid in binary; the file holds them to 1 ms.
      ASSERT_EQ(back.time_s[i], mic::parse_iso8601(mic::format_iso8601(record.time_s[i], 3)));
      ASSERT_NEAR(back.time_s[i], record.time_s[i], 1e-6);
      for (int c = 0; c < 3; ++c) {
        const double expected = record.values_nT(i, c);
        if (std::isnan(expected)) {
          ASSERT_TRUE(std::isnan(back.values_nT(i, c))) << i << " " << c;
        } else {
          ASSERT_NEAR(back.values_nT(i, c), expected, 0.005 + 1e-9) << i << " " << c;
        }
      }
    }
  }
  const std::string gz = read_bytes(dir + "/tst.sec.gz");
  ASSERT_GE(gz.size(), 2u);
  EXPECT_EQ(static_cast<unsigned char>(gz[0]), 0x1f);  // gzip magic
  EXPECT_EQ(static_cast<unsigned char>(gz[1]), 0x8b);

  const std::string bytes = read_bytes(dir + "/tst.sec");
  expect_iaga_layout(bytes);
  EXPECT_TRUE(contains(bytes, "\r\n2025-05-13 23:35:00.700 133     99999.00"));  // sample 7
  EXPECT_TRUE(contains(bytes, "\r\nDATE       TIME         DOY     TSTX      TSTY      TSTZ      "
                              "TSTF   |\r\n"));
  EXPECT_TRUE(contains(bytes, "\r\n IAGA Code              TST                        "));
}

TEST(WriteIaga2002, TimesOnTheMillisecondGridRoundTripExactly) {
  mic::VectorRecord record;
  record.values_nT = mic::Readings::Zero(4, 3);
  record.time_s = {kMay14 + 0.001, kMay14 + 0.123, kMay14 + 59.999, kMay14 + 86400.5};
  const std::string path = make_temp_dir("iaga_ms") + "/ms.sec";
  mic::write_iaga2002(path, record);
  const mic::VectorRecord back = mic::read_iaga2002(path);
  ASSERT_EQ(back.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(back.time_s[i], record.time_s[i]) << i;
  EXPECT_TRUE(contains(read_bytes(path), "2025-05-15 00:00:00.500 135"));
}

TEST(WriteIaga2002, CommentsAreWordWrappedAndReadBack) {
  mic::VectorRecord record;
  record.station = "WIC";
  record.time_s = {kMay14, kMay14 + 1.0};
  record.values_nT = mic::Readings::Constant(2, 3, 1.0);
  const std::string paragraph =
      "Calibrated in situ against the LEMI-036 reference: scale factors, non-orthogonality "
      "angles and the misalignment rotation were estimated in the 100-5000 s band. "
      "Supercalifragilisticexpialidociousandevenlongerthanonerecordcanholdxxxxxxxxxxxxxxxxx end";
  mic::Iaga2002WriteOptions options;
  options.comments = {paragraph, "second\nthird"};
  const std::string path = make_temp_dir("iaga_comments") + "/c.sec";
  mic::write_iaga2002(path, record, options);
  const std::string bytes = read_bytes(path);
  expect_iaga_layout(bytes);
  const std::vector<std::string> lines = read_lines(path);
  std::vector<std::string> comment_lines;
  for (const std::string& line : lines) {
    if (line.compare(0, 3, " # ") == 0) comment_lines.push_back(line);
  }
  ASSERT_EQ(comment_lines.size(), 7u);  // 5 for the paragraph, "second", "third"
  EXPECT_EQ(comment_lines[0],
            " # Calibrated in situ against the LEMI-036 reference: scale factors, |");
  EXPECT_EQ(comment_lines[3],
            " # Supercalifragilisticexpialidociousandevenlongerthanonerecordcanhol|");
  EXPECT_EQ(comment_lines[4],
            " # dxxxxxxxxxxxxxxxxx end                                            |");
  EXPECT_EQ(comment_lines[5],
            " # second                                                            |");

  const mic::VectorRecord back = mic::read_iaga2002(path);
  std::string joined = back.header.at("comments");
  const std::size_t second = joined.find("\nsecond\nthird");
  ASSERT_NE(second, std::string::npos);
  std::string first = joined.substr(0, second);
  // Joining the wrapped records with spaces gives the paragraph back, except where the long
  // word was cut (a cut adds a line break, not a space).
  const std::size_t cut = first.find("Supercal");
  ASSERT_NE(cut, std::string::npos);
  for (std::size_t i = 0; i < cut; ++i) {
    if (first[i] == '\n') first[i] = ' ';
  }
  first.erase(std::remove(first.begin() + cut, first.end(), '\n'), first.end());
  EXPECT_EQ(first, paragraph);
  EXPECT_EQ(joined.substr(second), "\nsecond\nthird");
}

TEST(WriteIaga2002, RefusesWhatCannotBeWrittenAndLeavesNoFile) {
  const std::string dir = make_temp_dir("iaga_refuse");
  mic::VectorRecord record;
  record.station = "WIC";
  record.time_s = {kMay14, kMay14 + 1.0};
  record.values_nT = mic::Readings::Constant(2, 3, 1.0);

  auto message_of = [&](const mic::VectorRecord& r, const mic::Iaga2002WriteOptions& o) {
    try {
      mic::write_iaga2002(dir + "/refused.sec", r, o);
    } catch (const mic::InputError& error) {
      return std::string(error.what());
    }
    return std::string();
  };
  const mic::Iaga2002WriteOptions defaults;

  mic::VectorRecord bad = record;
  bad.values_nT(1, 2) = 88887.996;  // would print as 88888.00, read back as missing
  EXPECT_TRUE(contains(message_of(bad, defaults), "refused.sec: sample 1")) << message_of(bad, defaults);
  bad = record;
  bad.values_nT(0, 0) = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(contains(message_of(bad, defaults), "cannot be written"));
  bad = record;
  bad.time_s[1] = kMay14 + 0.0004;  // same millisecond as sample 0
  EXPECT_TRUE(contains(message_of(bad, defaults), "is not after the previous sample"));
  bad = record;
  bad.time_s.clear();
  bad.values_nT.resize(0, 3);
  EXPECT_TRUE(contains(message_of(bad, defaults), "empty record"));
  bad = record;
  bad.components[1] = "too long name";
  EXPECT_TRUE(contains(message_of(bad, defaults), "component name"));
  mic::Iaga2002WriteOptions long_source;
  long_source.source_of_data = std::string(46, 'x');
  EXPECT_TRUE(contains(message_of(record, long_source), "'Source of Data' is 46 characters"));
  std::ifstream refused(dir + "/refused.sec");
  EXPECT_FALSE(refused.good());  // nothing was created

  // Just below the sentinel is fine.
  record.values_nT(1, 2) = 88887.99;
  mic::write_iaga2002(dir + "/fine.sec", record);
  EXPECT_EQ(mic::read_iaga2002(dir + "/fine.sec").values_nT(1, 2), 88887.99);
}

TEST(TextLineReader, StripsCrlfCountsLinesAndReadsGzip) {
  const std::string dir = make_temp_dir("text_lines");
  write_bytes(dir + "/mixed.txt", "first\r\nsecond\n\r\n" + std::string(10000, 'x') + "\nlast");
  mic::TextLineReader reader(dir + "/mixed.txt");
  std::string line;
  EXPECT_EQ(reader.line_number(), 0u);
  ASSERT_TRUE(reader.next(line));
  EXPECT_EQ(line, "first");
  ASSERT_TRUE(reader.next(line));
  EXPECT_EQ(line, "second");
  ASSERT_TRUE(reader.next(line));
  EXPECT_EQ(line, "");
  ASSERT_TRUE(reader.next(line));
  EXPECT_EQ(line, std::string(10000, 'x'));  // longer than the internal buffer
  ASSERT_TRUE(reader.next(line));
  EXPECT_EQ(line, "last");  // no final line end
  EXPECT_EQ(reader.line_number(), 5u);
  EXPECT_FALSE(reader.next(line));
  EXPECT_FALSE(reader.next(line));

  mic::TextFileWriter writer(dir + "/out.txt.gz");
  writer.write("a\r\nb\r\n");
  writer.close();
  EXPECT_EQ(read_lines(dir + "/out.txt.gz"), (std::vector<std::string>{"a", "b"}));

  // A gzip file cut short is an error, not a silent end.
  const std::string gz = read_bytes(package_data("wic20250514_lemi036.sec.gz"));
  write_bytes(dir + "/cut.sec.gz", gz.substr(0, gz.size() / 2));
  try {
    mic::TextLineReader cut(dir + "/cut.sec.gz");
    while (cut.next(line)) {
    }
    ADD_FAILURE() << "truncated gzip read without error";
  } catch (const mic::InputError& error) {
    EXPECT_TRUE(contains(error.what(), "cut.sec.gz:")) << error.what();
  }
}
