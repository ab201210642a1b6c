// export_corrected as a user runs it: the simulated test record corrected into the reference
// frame equals the clean field within the noise; the IAGA-2002 it writes reads back equal to
// r = t n^-1 (to the 0.01 nT of the format); header and comments; refusals; the real WIC pair.
#include "magnetometer_insitu_calibration/formats/csv_record.hpp"
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include "archive_fixtures.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <Eigen/LU>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace mic = magnetometer_insitu_calibration;

namespace {

using mic::test::ProgramRun;
using mic::test::run_program;

ProgramRun export_corrected(const std::string& args) { return run_program(EXPORT_CORRECTED_BIN, args); }

using magnetometer_insitu_calibration::test::read_json;

void write_json(const std::string& path, const nlohmann::json& j) {
  std::ofstream out(path);
  out << j.dump(2) << "\n";
}

double round2(double v) {  // what "%10.2f" followed by reading back gives
  char b[32];
  std::snprintf(b, sizeof b, "%.2f", v);
  return std::strtod(b, nullptr);
}

/// Residual statistics of `a` - `b` per component.
struct Residual {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero(), rms_about_mean = Eigen::Vector3d::Zero(), max_abs = Eigen::Vector3d::Zero();
};

Residual residual(const mic::Readings& a, const mic::Readings& b) {
  Residual r;
  const mic::Readings d = a - b;
  r.mean = d.colwise().mean().transpose();
  for (int c = 0; c < 3; ++c) {
    r.rms_about_mean(c) = std::sqrt((d.col(c).array() - r.mean(c)).square().mean());
    r.max_abs(c) = d.col(c).cwiseAbs().maxCoeff();
  }
  return r;
}

/// The rounded values the writer must produce for t n^-1.
void expect_rounded_correction(const mic::VectorRecord& out, const mic::VectorRecord& test,
                                      const Eigen::Matrix3d& n) {
  ASSERT_EQ(out.size(), test.size());
  EXPECT_EQ(out.time_s, test.time_s);
  const mic::Readings exact = test.values_nT * n.inverse();
  std::size_t differ = 0;
  for (Eigen::Index i = 0; i < exact.rows(); ++i) {
    for (int c = 0; c < 3; ++c) {
      // The rounding of t n^-1 computed here and in the program may differ at an exact tie.
      differ += out.values_nT(i, c) != round2(exact(i, c));
      ASSERT_LE(std::abs(out.values_nT(i, c) - exact(i, c)), 0.005 + 1e-9) << i << " " << c;
    }
  }
  EXPECT_LE(differ, static_cast<std::size_t>(exact.size() / 1000)) << "values differing from the rounded t n^-1";
}


}  // namespace

// The fixture outside the anonymous namespace: its tests' classes are global, and this file is
// compiled in one translation unit with its concern's others (-Wsubobject-linkage).
class ExportCorrected : public ::testing::Test {
 protected:
  // One day at 1 Hz with known n_true, no offset: the corrected test should be the clean field.
  static void SetUpTestSuite() {
    dir_ = mic::test::make_temp_dir("export");
    mic::SimulationSettings s;
    s.duration_s = 86400.0;
    pair_ = mic::simulate_pair(s);
    pair_.reference.station = "SIM";
    pair_.test.station = "SIM";
    mic::Iaga2002WriteOptions options;
    options.station_name = "Simulated test";
    options.comments = {"simulated test record"};
    mic::write_iaga2002(dir_ + "/test.sec", pair_.test, options);
    options.station_name = "Simulated reference";
    mic::write_iaga2002(dir_ + "/reference.sec", pair_.reference, options);
    test_read_ = mic::read_iaga2002(dir_ + "/test.sec");
    const ProgramRun r = run_program(CALIBRATE_RECORDS_BIN, "--reference " + dir_ + "/reference.sec --test " + dir_ +
                                                 "/test.sec --intervals 2 --json " + dir_ + "/report.json");
    ASSERT_EQ(r.status, 0) << r.output;
    // The same report with the true matrix in every window: the correction alone is then tested.
    nlohmann::json truth = read_json(dir_ + "/report.json");
    for (auto& w : truth["windows"]) {
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) w["matrix"][i][j] = pair_.n_true(i, j);
      }
    }
    write_json(dir_ + "/truth_report.json", truth);
  }

  static std::string dir_;
  static mic::SimulatedPair pair_;
  static mic::VectorRecord test_read_;
};
std::string ExportCorrected::dir_;
mic::SimulatedPair ExportCorrected::pair_;
mic::VectorRecord ExportCorrected::test_read_;

TEST_F(ExportCorrected, WithTheTrueMatrixTheOutputIsTheCleanFieldPlusTheNoise) {
  const ProgramRun r = export_corrected("--test " + dir_ + "/test.sec --calibration " + dir_ + "/truth_report.json -o " +
                                 dir_ + "/truth.sec");
  ASSERT_EQ(r.status, 0) << r.output;
  const mic::VectorRecord out = mic::read_iaga2002(dir_ + "/truth.sec");
  expect_rounded_correction(out, test_read_, pair_.n_true);
  // Left: the test noise (0.01 nT white + 1/f) and two roundings to 0.01 nT.
  const Residual e = residual(out.values_nT, pair_.field_nT);
  for (int c = 0; c < 3; ++c) {
    EXPECT_LT(std::abs(e.mean(c)), 0.01) << c;
    EXPECT_LT(e.rms_about_mean(c), 0.04) << c;
    EXPECT_LT(e.max_abs(c), 0.25) << c;
  }
}

TEST_F(ExportCorrected, WithTheEstimatedMatrixTheOutputIsTheCleanFieldWithinTheCalibrationUncertainty) {
  const ProgramRun r =
      export_corrected("--test " + dir_ + "/test.sec --calibration " + dir_ + "/report.json -o " + dir_ + "/est.sec");
  ASSERT_EQ(r.status, 0) << r.output;
  const nlohmann::json report = read_json(dir_ + "/report.json");
  const nlohmann::json& whole = report["windows"][2];
  ASSERT_EQ(whole["label"], "whole record");
  Eigen::Matrix3d n, se;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      n(i, j) = whole["matrix"][i][j];
      se(i, j) = whole["matrix_stderr"][i][j];
    }
  }
  const mic::VectorRecord out = mic::read_iaga2002(dir_ + "/est.sec");
  expect_rounded_correction(out, test_read_, n);
  // r - B = B (n_true - n) n^-1 + noise (first order, n^-1 ~ I). With B = B_mean + b(t): a constant
  // offset B_mean (n_true - n), which the calibration cannot see (harmonic 0 is not used; the
  // baseline comes from absolute measurements), and a variation part b(t) (n_true - n) on top
  // of the noise. Both bounded at 4 sigma from the report's standard errors of n; the noise
  // (0.028 nT rms with the true matrix, previous test) at 0.035 nT.
  const Eigen::RowVector3d mean_field = pair_.field_nT.colwise().mean();
  const Eigen::RowVector3d field_variance =
      (pair_.field_nT.rowwise() - mean_field).array().square().colwise().mean();
  const Residual e = residual(out.values_nT, pair_.field_nT);
  for (int c = 0; c < 3; ++c) {
    double offset_variance = 0.0, variation_variance = 0.0;
    for (int k = 0; k < 3; ++k) {
      offset_variance += std::pow(mean_field(k) * se(k, c), 2);
      variation_variance += field_variance(k) * se(k, c) * se(k, c);
    }
    EXPECT_LT(std::abs(e.mean(c)), 4.0 * std::sqrt(offset_variance)) << c;
    EXPECT_LT(e.rms_about_mean(c), std::sqrt(0.035 * 0.035 + 16.0 * variation_variance)) << c;
  }
}

TEST_F(ExportCorrected, Iaga2002HeaderAndCommentsStateTheCalibration) {
  const ProgramRun r = export_corrected("--test " + dir_ + "/test.sec --calibration " + dir_ + "/report.json --window 1" +
                                 " --iaga-code SIC --station-name 'Simulated corrected' --latitude 47.930 -o " + dir_ +
                                 "/header.sec.gz");
  ASSERT_EQ(r.status, 0) << r.output;
  // gzip: read the lines through the library's reader (the format's CRLF is checked on a plain file below).
  const ProgramRun plain = export_corrected("--test " + dir_ + "/test.sec --calibration " + dir_ +
                                     "/report.json --window 1 --iaga-code SIC -o " + dir_ + "/header.sec");
  ASSERT_EQ(plain.status, 0) << plain.output;
  std::ifstream raw(dir_ + "/header.sec", std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(raw)), std::istreambuf_iterator<char>());
  std::vector<std::string> lines;
  for (std::size_t start = 0; start < text.size();) {
    const std::size_t end = text.find("\r\n", start);
    ASSERT_NE(end, std::string::npos) << "every record ends in CRLF";
    lines.push_back(text.substr(start, end - start));
    start = end + 2;
  }
  for (const std::string& line : lines) ASSERT_EQ(line.size(), 70u) << "'" << line << "'";
  const char* keys[12] = {"Format", "Source of Data", "Station Name", "IAGA Code", "Geodetic Latitude",
                          "Geodetic Longitude", "Elevation", "Reported", "Sensor Orientation", "Digital Sampling",
                          "Data Interval Type", "Data Type"};
  for (int k = 0; k < 12; ++k) EXPECT_EQ(lines[k].substr(1, std::strlen(keys[k])), keys[k]) << k;
  EXPECT_NE(lines[3].find("SIC"), std::string::npos);
  std::string comments;
  for (const std::string& line : lines) {
    if (line.compare(0, 3, " # ") == 0) comments += line.substr(3, 66) + "\n";
  }
  const nlohmann::json first = read_json(dir_ + "/report.json")["windows"][0];
  char row[96];
  std::snprintf(row, sizeof row, "n row 1: %+.10f %+.10f %+.10f", first["matrix"][0][0].get<double>(),
                first["matrix"][0][1].get<double>(), first["matrix"][0][2].get<double>());
  for (const std::string& expected : {std::string("r = t n^-1"), std::string(row), std::string("'interval 1/2'"),
                                      first["window_start"].get<std::string>(), std::string("report.json"),
                                      std::string("Baseline"), std::string("simulated test record")}) {
    EXPECT_NE(comments.find(expected), std::string::npos) << expected << " not in\n" << comments;
  }
  const mic::VectorRecord gz = mic::read_iaga2002(dir_ + "/header.sec.gz");
  EXPECT_EQ(gz.header.at("Station Name"), "Simulated corrected");
  EXPECT_EQ(gz.header.at("Geodetic Latitude"), "47.930");
  EXPECT_EQ(gz.station, "SIC");
  std::string why;
  EXPECT_TRUE(mic::test::same_samples(gz, mic::read_iaga2002(dir_ + "/header.sec"), &why)) << why;
}

TEST_F(ExportCorrected, FlaggedWindowsAndBadRequestsAreRefusedWithTheReason) {
  nlohmann::json flagged = read_json(dir_ + "/report.json");
  flagged["windows"][2]["quality"] = "low_coherence";
  write_json(dir_ + "/flagged.json", flagged);
  ProgramRun r = export_corrected("--test " + dir_ + "/test.sec --calibration " + dir_ + "/flagged.json -o " + dir_ + "/f.sec");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("low_coherence"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--allow-flagged"), std::string::npos) << r.output;
  r = export_corrected("--test " + dir_ + "/test.sec --calibration " + dir_ + "/flagged.json --allow-flagged -o " +
                       dir_ + "/f.sec");
  EXPECT_EQ(r.status, 0) << r.output;
  r = export_corrected("--test " + dir_ + "/test.sec --calibration " + dir_ + "/report.json --window 'interval 9/9' -o " +
                       dir_ + "/f.sec");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("no window labelled 'interval 9/9'"), std::string::npos) << r.output;
  r = export_corrected("--calibration " + dir_ + "/report.json -o " + dir_ + "/f.sec");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("--test"), std::string::npos) << r.output;
  r = export_corrected("--test " + dir_ + "/nope.sec --calibration " + dir_ + "/report.json -o " + dir_ + "/f.sec");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("nope.sec"), std::string::npos) << r.output;
}

TEST_F(ExportCorrected, ARecordOfOtherComponentsThanTheCalibratedOnesIsRefused) {
  // The report names the test components n was estimated on (X, Y, Z here); the same record
  // written as H, D, Z is refused, naming both, and nothing is written. Names differing only in
  // letter case (a CSV's x, y, z) are the same axes.
  const nlohmann::json report = read_json(dir_ + "/report.json");
  ASSERT_EQ(report["preprocessing"]["test_components"], nlohmann::json::array({"X", "Y", "Z"}));
  ASSERT_EQ(report["preprocessing"]["reference_components"], nlohmann::json::array({"X", "Y", "Z"}));
  mic::VectorRecord hdz = test_read_;
  hdz.components = {"H", "D", "Z"};
  const std::string hdz_path = dir_ + "/test_hdz.sec", out = dir_ + "/hdz_corrected.sec";
  mic::write_iaga2002(hdz_path, hdz, mic::Iaga2002WriteOptions{});
  ASSERT_EQ(mic::read_iaga2002(hdz_path).components, hdz.components);
  std::remove(out.c_str());
  ProgramRun r = export_corrected("--test " + hdz_path + " --calibration " + dir_ + "/report.json -o " + out);
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find(hdz_path + ": components H,D,Z, but " + dir_ + "/report.json was estimated on a test record of "
                          "components X,Y,Z"), std::string::npos) << r.output;
  EXPECT_FALSE(std::ifstream(out).good()) << out << " written from a refused record";
  // Lower-case names of the same axes (a CSV header's x, y, z) pass, with the same correction.
  const std::string csv = dir_ + "/test_lower.csv";
  mic::VectorRecord lower = test_read_;
  lower.components = {"x", "y", "z"};
  mic::write_csv_record(csv, lower);
  r = export_corrected("--test " + csv + " --calibration " + dir_ + "/truth_report.json -o " + dir_ + "/lower.sec");
  ASSERT_EQ(r.status, 0) << r.output;
  expect_rounded_correction(mic::read_iaga2002(dir_ + "/lower.sec"), test_read_, pair_.n_true);
  // A report written before it named the components is applied as before: t n^-1.
  nlohmann::json earlier = read_json(dir_ + "/truth_report.json");
  earlier["preprocessing"].erase("test_components");
  write_json(dir_ + "/earlier.json", earlier);
  r = export_corrected("--test " + hdz_path + " --calibration " + dir_ + "/earlier.json -o " + out);
  ASSERT_EQ(r.status, 0) << r.output;
  expect_rounded_correction(mic::read_iaga2002(out), test_read_, pair_.n_true);
}

// The reference the report was estimated against, given as --test (the same file, under another
// spelling of its path), is refused naming it, and nothing is written: n corrects the test.
TEST_F(ExportCorrected, TheReportsOwnReferenceIsRefusedAsTheTest) {
  const std::string out = dir_ + "/reference_corrected.sec";
  const std::string spelled = dir_ + "/../" + dir_.substr(dir_.rfind('/') + 1) + "/reference.sec";
  const ProgramRun r = export_corrected("--test " + spelled + " --calibration " + dir_ + "/report.json -o " + out);
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find(spelled + ": is the reference " + dir_ + "/report.json was estimated against, not its test"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(std::ifstream(out).good()) << out << " written from the reference";
}

// The report lists its files one by one (settings.reference_files): a reference whose name
// holds " + " (the separator of settings.reference) is still known as the reference; a report
// without the list (an older one) is split at " + ", as before.
TEST_F(ExportCorrected, TheReferenceIsKnownByItsListedFilesWhateverTheirNames) {
  const std::string plus = dir_ + "/reference + copy.sec", out = dir_ + "/plus_corrected.sec";
  std::filesystem::copy_file(dir_ + "/reference.sec", plus, std::filesystem::copy_options::overwrite_existing);
  ProgramRun r = run_program(CALIBRATE_RECORDS_BIN, "--reference '" + plus + "' --test " + dir_ + "/test.sec --json " +
                                                        dir_ + "/plus_report.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const nlohmann::json report = read_json(dir_ + "/plus_report.json");
  EXPECT_EQ(report["settings"]["reference_files"], nlohmann::json::array({plus}));
  EXPECT_EQ(report["settings"]["test_files"], nlohmann::json::array({dir_ + "/test.sec"}));
  r = export_corrected("--test '" + plus + "' --calibration " + dir_ + "/plus_report.json -o " + out);
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find(plus + ": is the reference " + dir_ + "/plus_report.json was estimated against"), std::string::npos)
      << r.output;
  EXPECT_FALSE(std::filesystem::exists(out));
  nlohmann::json earlier = read_json(dir_ + "/report.json");
  earlier["settings"].erase("reference_files");
  write_json(dir_ + "/earlier_files.json", earlier);
  r = export_corrected("--test " + dir_ + "/reference.sec --calibration " + dir_ + "/earlier_files.json -o " + out);
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST_F(ExportCorrected, ADamagedCsvLineIsRefusedAsCalibrateRecordsRefusesItAndNothingIsWritten) {
  // Text in a number column (line 5, column 3 "y"): export_corrected refuses the record as
  // calibrate_records does, naming file, line and column, exits 1 and writes no output file.
  const std::string bad = dir_ + "/damaged.csv", out = dir_ + "/damaged_corrected.sec";
  {
    std::ofstream csv(bad);
    csv << "time,x,y,z\n";
    for (int k = 0; k < 6; ++k) {
      csv << 1747180800 + k << ",20000.5," << (k == 3 ? std::string("abc") : std::string("1500.25")) << ",44000.75\n";
    }
  }
  std::remove(out.c_str());
  const std::string expected = bad + ":5: column 3 (y): 'abc' is not a number";
  const ProgramRun r = export_corrected("--test " + bad + " --calibration " + dir_ + "/report.json -o " + out);
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find(expected), std::string::npos) << r.output;
  EXPECT_FALSE(std::ifstream(out).good()) << out << " written from a refused record";
  const ProgramRun c = run_program(CALIBRATE_RECORDS_BIN, "--reference " + dir_ + "/reference.sec --test " + bad);
  EXPECT_NE(c.status, 0) << c.output;
  EXPECT_NE(c.output.find(expected), std::string::npos) << c.output;
}

// The real Conrad Observatory pair (data/README.md): the DTU FGE record corrected with the
// day's calibration against the LEMI-036.
TEST(ExportCorrectedWic, FgeDayCorrectedIntoTheLemiFrame) {
  const std::string dir = mic::test::make_temp_dir("export_wic");
  const std::string lemi = mic::test::package_data("wic20250514_lemi036.sec.gz");
  const std::string fge = mic::test::package_data("wic20250514_fge.sec.gz");
  ProgramRun r = run_program(CALIBRATE_RECORDS_BIN, "--reference " + lemi + " --test " + fge + " --json " + dir + "/day.json");
  ASSERT_EQ(r.status, 0) << r.output;
  r = export_corrected("--test " + fge + " --calibration " + dir + "/day.json -o " + dir + "/fge_corrected.sec");
  ASSERT_EQ(r.status, 0) << r.output;
  const nlohmann::json day = read_json(dir + "/day.json")["windows"][0];
  Eigen::Matrix3d n;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) n(i, j) = day["matrix"][i][j];
  }
  const mic::VectorRecord test = mic::read_record(fge);
  const mic::VectorRecord out = mic::read_iaga2002(dir + "/fge_corrected.sec");
  EXPECT_EQ(out.station, "WIC");
  EXPECT_EQ(out.components, test.components);  // H, E, Z
  EXPECT_EQ(out.size(), 86400u);
  expect_rounded_correction(out, test, n);
}
