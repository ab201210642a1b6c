// The text readers' options for a file still being written and a clock that steps
// (TextReadOptions, text_lines.hpp), on pieces of the real WIC day and on CSV: a last line without
// a line end not read at all, a gzip stream cut short read up to its last complete line, lines
// stamped backwards or ahead of a bound skipped and counted instead of refusing the file; the
// defaults unchanged.
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/csv_record.hpp"
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"
#include "wic_day_pieces.hpp"

#include <gtest/gtest.h>

#include <zlib.h>

#include <string>

namespace mic = magnetometer_insitu_calibration;

namespace {

mic::TextReadOptions complete_lines_only() {
  mic::TextReadOptions o;
  o.complete_lines_only = true;
  return o;
}

mic::TextReadOptions skipping(double latest_s = std::numeric_limits<double>::infinity()) {
  mic::TextReadOptions o;
  o.skip_out_of_order = true;
  o.latest_time_s = latest_s;
  return o;
}

std::string gzip_bytes(const std::string& text) {
  uLongf size = compressBound(static_cast<uLong>(text.size())) + 64;
  std::string out(size, '\0');
  z_stream z{};
  deflateInit2(&z, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY);  // gzip wrapper
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(text.data()));
  z.avail_in = static_cast<uInt>(text.size());
  z.next_out = reinterpret_cast<Bytef*>(&out[0]);
  z.avail_out = static_cast<uInt>(out.size());
  deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  return out;
}

}  // namespace

TEST(TextReadOptions, ALastLineWithoutLineEndIsNotReadUntilItEnds) {
  const std::string dir = mic::test::make_temp_dir("text_options_held");
  const std::string path = dir + "/wic.sec";
  const std::string& next = mic::test::wic_day().data[100];
  // Cut within the line (default: dropped, cut short) and whole but without its line end
  // (default: kept, a complete line). Complete lines only: neither is read, both are noted.
  for (const std::string& partial : {next.substr(0, 40), next}) {
    SCOPED_TRACE(partial);
    mic::test::write_bytes(path, mic::test::iaga_text(mic::test::wic_lines(0, 100), partial));
    const mic::VectorRecord held = mic::read_iaga2002(path, complete_lines_only());
    ASSERT_EQ(held.size(), 100u);
    EXPECT_EQ(held.time_s.back(), mic::test::wic_time_s(99));
    ASSERT_EQ(held.header.count(mic::kHeldLastLineKey), 1u);
    EXPECT_NE(held.header.at(mic::kHeldLastLineKey).find(path + ":120: last line not read"), std::string::npos)
        << held.header.at(mic::kHeldLastLineKey);
    const mic::VectorRecord strict = mic::read_iaga2002(path);
    EXPECT_EQ(strict.size(), partial == next ? 101u : 100u);
    EXPECT_EQ(strict.header.count(mic::kHeldLastLineKey), 0u);
  }
  // The line ended: read.
  mic::test::write_bytes(path, mic::test::iaga_text(mic::test::wic_lines(0, 101)));
  const mic::VectorRecord ended = mic::read_iaga2002(path, complete_lines_only());
  EXPECT_EQ(ended.size(), 101u);
  EXPECT_EQ(ended.header.count(mic::kHeldLastLineKey), 0u);
  // The same through read_record, which passes the options on.
  mic::test::write_bytes(path, mic::test::iaga_text(mic::test::wic_lines(0, 100), next));
  EXPECT_EQ(mic::read_record(path, mic::LemiReadOptions(), nullptr, complete_lines_only()).size(), 100u);
}

TEST(TextReadOptions, AFileWithoutADataLineYetIsAnEmptyRecord) {
  const std::string dir = mic::test::make_temp_dir("text_options_empty");
  const std::string iaga = dir + "/wic.sec", csv = dir + "/obs.csv";
  mic::test::write_bytes(iaga, mic::test::iaga_text({}, mic::test::wic_day().data[0].substr(0, 30)));
  mic::test::write_bytes(csv, "time,X,Y,Z\n2025-05-14T00:00:00Z,1.5,");
  for (const std::string& path : {iaga, csv}) {
    SCOPED_TRACE(path);
    const mic::VectorRecord r = mic::read_record(path, mic::LemiReadOptions(), nullptr, complete_lines_only());
    EXPECT_TRUE(r.empty());
    EXPECT_EQ(r.header.count(mic::kHeldLastLineKey), 1u);
    EXPECT_THROW(mic::read_record(path), mic::InputError);  // the strict rule: no data lines
  }
  EXPECT_EQ(mic::read_iaga2002(iaga, complete_lines_only()).station, "WIC");
}

TEST(TextReadOptions, AGzipStreamCutShortGivesItsCompleteLines) {
  const std::string dir = mic::test::make_temp_dir("text_options_gzip");
  const std::string path = dir + "/wic.sec.gz";
  const std::string whole = gzip_bytes(mic::test::iaga_text(mic::test::wic_lines(0, 3000)));
  mic::test::write_bytes(path, whole.substr(0, whole.size() / 2));  // a download in progress
  EXPECT_THROW(mic::read_iaga2002(path), mic::InputError);
  const mic::VectorRecord r = mic::read_iaga2002(path, complete_lines_only());
  EXPECT_GT(r.size(), 100u);
  EXPECT_LT(r.size(), 3000u);
  EXPECT_EQ(r.header.count(mic::kHeldLastLineKey), 1u);
  for (std::size_t k = 0; k < r.size(); ++k) ASSERT_EQ(r.time_s[k], mic::test::wic_time_s(k));
}

TEST(TextReadOptions, LinesStampedBackwardsOrAheadAreSkippedAndCounted) {
  const std::string dir = mic::test::make_temp_dir("text_options_skip");
  const std::string path = dir + "/wic.sec";
  // Records 0..199, then the clock steps back 60 s: records 200..259 stamped 140..199, then on.
  std::vector<std::string> lines = mic::test::wic_lines(0, 200);
  for (std::size_t k = 200; k < 260; ++k) lines.push_back(mic::test::wic_line_stamped(k, k - 60));
  for (const std::string& line : mic::test::wic_lines(260, 400)) lines.push_back(line);
  lines.insert(lines.begin() + 300, mic::test::wic_line_stamped(300, 86000));  // one stamp hours ahead
  mic::test::write_bytes(path, mic::test::iaga_text(lines));
  try {
    mic::read_iaga2002(path);
    ADD_FAILURE() << "the strict reader kept a file whose time goes backwards";
  } catch (const mic::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("time goes backwards"), std::string::npos) << e.what();
  }
  // Skipped: the 60 stamped backwards; with the bound, the one ahead too.
  const mic::VectorRecord r = mic::read_iaga2002(path, skipping(mic::test::wic_time_s(1000)));
  ASSERT_EQ(r.size(), 340u);
  for (std::size_t k = 1; k < r.size(); ++k) ASSERT_GT(r.time_s[k], r.time_s[k - 1]);
  EXPECT_EQ(r.time_s[200], mic::test::wic_time_s(260));
  EXPECT_EQ(r.values_nT(200, 0), mic::read_iaga2002(mic::test::package_data("wic20250514_lemi036.sec.gz")).values_nT(260, 0));
  EXPECT_EQ(mic::noted_count(r.header, mic::kLinesBackwardsKey), 60u);
  EXPECT_EQ(mic::noted_count(r.header, mic::kLinesAheadKey), 1u);
  EXPECT_NE(r.header.at(mic::kFirstSkippedLineKey).find(path + ":220: line skipped: time 2025-05-14T00:02:20"),
            std::string::npos)
      << r.header.at(mic::kFirstSkippedLineKey);
  // Without the bound the stamp ahead is kept, and the 100 records after it are behind it.
  const mic::VectorRecord unbounded = mic::read_iaga2002(path, skipping());
  EXPECT_EQ(unbounded.time_s.back(), mic::test::wic_time_s(86000));
  EXPECT_EQ(mic::noted_count(unbounded.header, mic::kLinesBackwardsKey), 60u + 100u);
}

TEST(TextReadOptions, CsvLinesStampedBackwardsAreSkippedWithTheirAuxiliaryValues) {
  const std::string dir = mic::test::make_temp_dir("text_options_csv");
  const std::string path = dir + "/obs.csv";
  mic::test::write_bytes(path,
                         "time,X,Y,Z,temperature\n"
                         "100,1,2,3,20.0\n101,1,2,3,20.1\n100.5,9,9,9,99\n102,1,2,3,20.2\n102,8,8,8,98\n103,1,2,3,20.3\n");
  EXPECT_THROW(mic::read_csv_record(path), mic::InputError);
  const mic::VectorRecord r = mic::read_csv_record(path, skipping());
  ASSERT_EQ(r.size(), 4u);
  EXPECT_EQ(r.time_s, (std::vector<double>{100, 101, 102, 103}));
  ASSERT_EQ(r.auxiliary.size(), 1u);
  EXPECT_EQ(r.auxiliary[0].values, (std::vector<double>{20.0, 20.1, 20.2, 20.3}));
  EXPECT_EQ(mic::noted_count(r.header, mic::kLinesBackwardsKey), 2u);
}
