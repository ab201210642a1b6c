// Replays the inputs in fuzz/regressions/<target>/ (each one once crashed a fuzz target, see
// fuzz/README.md) through the reader of that target with the ordinary g++ build: each must give
// a record or the reader's documented InputError, never another exception. The inputs whose
// expected outcome is known are also checked one by one.
#include "magnetometer_insitu_calibration/formats/cdf_records.hpp"
#include "magnetometer_insitu_calibration/formats/csv_record.hpp"
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/lemi025_stream_parser.hpp"
#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <string>
#include <vector>

using namespace magnetometer_insitu_calibration;
namespace fs = std::filesystem;

namespace {

const fs::path kRegressions = fs::path(TEST_DATA_DIR) / ".." / ".." / "fuzz" / "regressions";

std::vector<std::uint8_t> bytes_of(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<std::uint8_t>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// The reader of each fuzz target, as the target calls it (fuzz/fuzz_<target>.cpp).
const std::map<std::string, std::function<void(const fs::path&)>>& readers() {
  static const std::map<std::string, std::function<void(const fs::path&)>> kReaders = {
      {"iaga2002", [](const fs::path& p) { read_iaga2002(p.string()); }},
      {"csv_record", [](const fs::path& p) { read_csv_record(p.string()); }},
      {"record_file",
       [](const fs::path& p) {
         detect_record_format(p.string());
         read_record(p.string());
       }},
      {"lemi_bin", [](const fs::path& p) { read_lemi_bin(p.string()); }},
      {"cdf", [](const fs::path& p) { read_cdf_record(p.string()); }},
      {"lemi_compact_flash", [](const fs::path& p) { read_lemi_compact_flash(p.string()); }},
      {"lemi025_stream", [](const fs::path& p) { read_lemi025_stream(p.string()); }},
      {"lemi025_packet",
       [](const fs::path& p) {
         std::vector<std::uint8_t> b = bytes_of(p);
         b.resize(kLemi025PacketSize, 0);
         decode_lemi025_packet(b.data());
       }},
      {"lemi025_stream_parser",
       [](const fs::path& p) {
         const std::vector<std::uint8_t> b = bytes_of(p);
         Lemi025StreamParser parser;
         if (b.size() > 2) parser.feed(b.data() + 2, b.size() - 2);
         parser.flush();
       }},
  };
  return kReaders;
}

// "" if the reader gave a record or an InputError, else what escaped.
std::string replay(const std::string& target, const fs::path& input) {
  try {
    readers().at(target)(input);
  } catch (const InputError&) {
  } catch (const std::exception& e) {
    return std::string("undocumented exception: ") + e.what();
  } catch (...) {
    return "undocumented non-std exception";
  }
  return "";
}

std::string input_error_of(const fs::path& input, const std::function<void(const std::string&)>& read) {
  try {
    read(input.string());
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

}  // namespace

TEST(FuzzRegressions, EveryInputGivesARecordOrInputError) {
  ASSERT_TRUE(fs::is_directory(kRegressions)) << kRegressions;
  std::size_t replayed = 0;
  for (const fs::directory_entry& dir : fs::directory_iterator(kRegressions)) {
    if (!dir.is_directory()) continue;
    const std::string target = dir.path().filename().string();
    if (readers().count(target) == 0) continue;  // e.g. calibration_yaml: ROS layer, not core
    for (const fs::directory_entry& input : fs::directory_iterator(dir.path())) {
      EXPECT_EQ(replay(target, input.path()), "") << target << ": " << input.path();
      ++replayed;
    }
  }
  EXPECT_GE(replayed, 5u);
}

// IAGA-2002: a DOY field of many digits overflowed an int while it was being read (UBSan:
// signed integer overflow); it is refused as "not a day of year".
TEST(FuzzRegressions, IagaLongDoyField) {
  const std::string what = input_error_of(kRegressions / "iaga2002" / "doy_int_overflow.sec",
                                          [](const std::string& p) { read_iaga2002(p); });
  EXPECT_NE(what.find(":2: DOY field: '99999999999' is not a day of year"), std::string::npos) << what;
}

// IAGA-2002: a duplicate time that rounds to year 10000 in the message made format_iso8601
// throw std::invalid_argument instead of the InputError naming the line.
TEST(FuzzRegressions, IagaDuplicateTimeAtYear9999) {
  const std::string what =
      input_error_of(kRegressions / "iaga2002" / "duplicate_time_rounds_to_year_10000.sec",
                     [](const std::string& p) { read_iaga2002(p); });
  EXPECT_NE(what.find(":3: DATE/TIME field: duplicate time 253402300799.9999"), std::string::npos) << what;
}

// CSV: times beyond year 9999 (UNIX seconds 1e17) that are not increasing made the error
// message throw std::invalid_argument instead of the InputError naming the line.
TEST(FuzzRegressions, CsvDuplicateTimeBeyondYear9999) {
  const std::string what =
      input_error_of(kRegressions / "csv_record" / "duplicate_time_beyond_year_9999.csv",
                     [](const std::string& p) { read_csv_record(p); });
  EXPECT_NE(what.find(":3: column 1 (time): duplicate time 1e+17 s (UNIX time) is not after 1e+17 s"),
            std::string::npos)
      << what;
}

TEST(FuzzRegressions, CsvBackwardsTimeRoundingToYear10000) {
  const std::string what =
      input_error_of(kRegressions / "csv_record" / "backwards_iso_rounds_to_year_10000.csv",
                     [](const std::string& p) { read_csv_record(p); });
  EXPECT_NE(what.find(":3: column 1 (time): time goes backwards: 253402300799.999"), std::string::npos)
      << what;
}

TEST(FuzzRegressions, RecordFileCsvBackwardsTimeBeyondYear9999) {
  const std::string what =
      input_error_of(kRegressions / "record_file" / "csv_backwards_time_beyond_year_9999.csv",
                     [](const std::string& p) { read_record(p); });
  EXPECT_NE(what.find(":4: column 1 (time): time goes backwards: 2025-05-14T00:00:05.000Z is not after "
                      "1747180807180804 s (UNIX time)"),
            std::string::npos)
      << what;
}
