// calibrate_records on observatory archives: straight from the WIC MagPy CDF pair (n as from the
// IAGA-2002 conversion), and the WIC day split into several files per instrument (exactly the
// single-file result, overlaps reported).
#include "magnetometer_insitu_calibration/formats/imagcdf_writer.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;
using mic::test::contains;
using mic::test::ProgramRun;

namespace {

ProgramRun run(const std::string& args) { return mic::test::run_program(CALIBRATE_RECORDS_BIN, args); }

using magnetometer_insitu_calibration::test::read_json;

/// Writes lines [first, last) of the data records of an IAGA-2002 file, after its header, to `path`.
void write_iaga_part(const std::vector<std::string>& lines, std::size_t first, std::size_t last, const std::string& path) {
  std::size_t header = 0;
  while (header < lines.size() && lines[header].compare(0, 4, "DATE") != 0) ++header;
  ASSERT_LT(header + last, lines.size() + 1);
  std::ofstream out(path, std::ios::binary);
  for (std::size_t i = 0; i <= header; ++i) out << lines[i] << "\r\n";
  for (std::size_t i = header + 1 + first; i < header + 1 + last; ++i) out << lines[i] << "\r\n";
}

/// Samples [first, last) of a record.
mic::VectorRecord slice(const mic::VectorRecord& r, std::size_t first, std::size_t last) {
  mic::VectorRecord out = r;
  out.time_s.assign(r.time_s.begin() + static_cast<long>(first), r.time_s.begin() + static_cast<long>(last));
  out.values_nT = r.values_nT.middleRows(static_cast<Eigen::Index>(first), static_cast<Eigen::Index>(last - first));
  for (mic::AuxiliaryChannel& a : out.auxiliary) {
    a.values.assign(a.values.begin() + static_cast<long>(first), a.values.begin() + static_cast<long>(last));
  }
  return out;
}

const std::string kLemiCdf = mic::test::test_data("cdf/LEMI036_1_0002_0002_2025-05-14.cdf");
const std::string kFgeCdf = mic::test::test_data("cdf/FGE_S0252_0002_0002_2025-05-14.cdf");
const std::string kLemiIaga = mic::test::package_data("wic20250514_lemi036.sec.gz");
const std::string kFgeIaga = mic::test::package_data("wic20250514_fge.sec.gz");

}  // namespace

TEST(CalibrateRecordsCdf, WicCdfPairGivesTheIagaMatrixWithinAFifthOfAStandardError) {
  const std::string dir = mic::test::make_temp_dir("cdf_cli");
  ProgramRun r = run("--reference " + kLemiIaga + " --test " + kFgeIaga + " --json " + dir + "/iaga.json");
  ASSERT_EQ(r.status, 0) << r.output;
  r = run("--reference " + mic::test::test_data("cdf/LEMI036_1_0002_0002_2025-05-14.cdf") + " --test " +
          mic::test::test_data("cdf/FGE_S0252_0002_0002_2025-05-14.cdf") + " --json " + dir + "/cdf.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const nlohmann::json iaga = read_json(dir + "/iaga.json"), cdf = read_json(dir + "/cdf.json");
  ASSERT_EQ(iaga["windows"].size(), cdf["windows"].size());
  for (std::size_t w = 0; w < iaga["windows"].size(); ++w) {
    const nlohmann::json &a = iaga["windows"][w], &b = cdf["windows"][w];
    EXPECT_EQ(a["samples"], b["samples"]);
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        const double se = a["matrix_stderr"][i][j];
        EXPECT_LT(std::abs(double(a["matrix"][i][j]) - double(b["matrix"][i][j])), 0.2 * se) << i << j;
      }
    }
  }
}

TEST(CalibrateRecordsCdf, DaySplitIntoFilesGivesExactlyTheSingleFileResult) {
  const std::string dir = mic::test::make_temp_dir("split_cli");
  // Each instrument: 00:00-13:53:19 and 12:00:00-23:59:59 (1h53m20s overlap, the same samples).
  for (const auto& [name, path] : {std::pair<std::string, std::string>{"lemi", kLemiIaga}, {"fge", kFgeIaga}}) {
    const std::vector<std::string> lines = mic::test::read_lines(path);
    write_iaga_part(lines, 0, 50000, dir + "/" + name + "_1.sec");
    write_iaga_part(lines, 43200, 86400, dir + "/" + name + "_2.sec");
  }
  ProgramRun r = run("--reference " + kLemiIaga + " --test " + kFgeIaga + " --intervals 4 --json " + dir + "/one.json");
  ASSERT_EQ(r.status, 0) << r.output;
  // The files in any order; windows span the boundary between files.
  r = run("--reference " + dir + "/lemi_2.sec " + dir + "/lemi_1.sec --test " + dir + "/fge_1.sec " + dir +
          "/fge_2.sec --intervals 4 --json " + dir + "/split.json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, dir + "/lemi_2.sec: 6800 samples from 2025-05-14T12:00:00.000Z to "
                                       "2025-05-14T13:53:19.000Z overlap " + dir + "/lemi_1.sec: dropped")) << r.output;
  EXPECT_TRUE(contains(r.output, "largest value difference at equal times 0.00 nT")) << r.output;
  const nlohmann::json one = read_json(dir + "/one.json"), split = read_json(dir + "/split.json");
  EXPECT_EQ(one["windows"], split["windows"]);
  EXPECT_EQ(one["preprocessing"], split["preprocessing"]);
  EXPECT_EQ(split["settings"]["reference"], dir + "/lemi_2.sec + " + dir + "/lemi_1.sec");  // as given
  ASSERT_EQ(one["windows"].size(), 5u);

  // A gap between files (the test's second file starts an hour late) is a gap as within one file.
  const std::vector<std::string> fge = mic::test::read_lines(kFgeIaga);
  write_iaga_part(fge, 0, 43200, dir + "/fge_a.sec");
  write_iaga_part(fge, 46800, 86400, dir + "/fge_b.sec");
  {  // the same gap inside one file: the hour's data lines removed
    std::vector<std::string> cut(fge.begin(), fge.end());
    std::size_t header = 0;
    while (cut[header].compare(0, 4, "DATE") != 0) ++header;
    cut.erase(cut.begin() + static_cast<long>(header + 1 + 43200), cut.begin() + static_cast<long>(header + 1 + 46800));
    std::ofstream out(dir + "/fge_gap.sec", std::ios::binary);
    for (const std::string& line : cut) out << line << "\r\n";
  }
  // The hour's gap (4.2 % of the day, not longer than max_fill's hour) is bridged: the day
  // passes, the same from one file as from two.
  r = run("--reference " + kLemiIaga + " --test " + dir + "/fge_gap.sec --json " + dir + "/gap_one.json");
  ASSERT_EQ(r.status, 0) << r.output;
  r = run("--reference " + kLemiIaga + " --test " + dir + "/fge_b.sec " + dir + "/fge_a.sec --json " + dir + "/gap_split.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const nlohmann::json gap_one = read_json(dir + "/gap_one.json"), gap_split = read_json(dir + "/gap_split.json");
  EXPECT_EQ(gap_one["windows"], gap_split["windows"]);
  EXPECT_EQ(gap_one["preprocessing"], gap_split["preprocessing"]);
  // The real day without its hour against the whole day: every scale ratio and
  // non-orthogonality within a fifth of the whole day's standard error (measured: at most 0.18).
  const nlohmann::json& cut_day = gap_one["windows"].back();
  const nlohmann::json whole_day = one["windows"].back();
  ASSERT_EQ(cut_day["quality"], "ok");
  EXPECT_EQ(cut_day["filled_samples"], 3600);
  for (int i = 0; i < 3; ++i) {
    const double se = whole_day["scale_ratio_ci95"][i].get<double>() / 1.96;
    EXPECT_LT(std::abs(cut_day["scale_ratio"][i].get<double>() - whole_day["scale_ratio"][i].get<double>()), 0.2 * se) << i;
  }
  for (const char* pair : {"xy", "xz", "yz"}) {
    const double se = whole_day["nonorthogonality_ci95_deg"][pair].get<double>() / 1.96;
    EXPECT_LT(std::abs(cut_day["nonorthogonality_deg"][pair].get<double>() -
                       whole_day["nonorthogonality_deg"][pair].get<double>()), 0.2 * se) << pair;
  }
  // A stricter user's --max-fill 60: the hour flags the day's one window (exit 3, the report
  // written); in quarters it flags its own (the third) and the day's, and the summary, of the
  // flagged day, points at the three that passed (exit 0).
  r = run("--reference " + kLemiIaga + " --test " + dir + "/fge_gap.sec --max-fill 60 --json " + dir + "/gap_strict.json");
  ASSERT_EQ(r.status, 3) << r.output;
  EXPECT_EQ(read_json(dir + "/gap_strict.json")["windows"].back()["quality"], "gaps");
  r = run("--reference " + kLemiIaga + " --test " + dir + "/fge_gap.sec --max-fill 60 --intervals 4");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("a gap longer than 60 s (--max-fill, ~max_fill)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("3 of the other 4 windows passed their rules"), std::string::npos) << r.output;
}

TEST(CalibrateRecordsCdf, CdfDaySplitIntoTwoImagCdfFilesGivesExactlyTheSingleFileResult) {
  const std::string dir = mic::test::make_temp_dir("split_cdf");
  for (const auto& [name, path] : {std::pair<std::string, std::string>{"lemi", kLemiCdf}, {"fge", kFgeCdf}}) {
    const mic::VectorRecord day = mic::read_record(path);
    mic::write_imagcdf(dir + "/" + name + "_1.cdf", slice(day, 0, 50000));
    mic::write_imagcdf(dir + "/" + name + "_2.cdf", slice(day, 43200, 86400));
  }
  ProgramRun r = run("--reference " + kLemiCdf + " --test " + kFgeCdf + " --intervals 4 --json " + dir + "/one.json");
  ASSERT_EQ(r.status, 0) << r.output;
  r = run("--reference " + dir + "/lemi_2.cdf " + dir + "/lemi_1.cdf --test " + dir + "/fge_1.cdf " + dir +
          "/fge_2.cdf --intervals 4 --json " + dir + "/split.json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, dir + "/fge_2.cdf: 6800 samples from 2025-05-14T12:00:00.000Z")) << r.output;
  const nlohmann::json one = read_json(dir + "/one.json"), split = read_json(dir + "/split.json");
  ASSERT_EQ(one["windows"].size(), 5u);
  EXPECT_EQ(one["windows"], split["windows"]);
  EXPECT_EQ(one["preprocessing"], split["preprocessing"]);
}
