// export_corrected to ImagCDF (.cdf): read by an independent reader, Debian's libjcdf-java
// (its CdfList tool), with the values of the IAGA-2002 export of the same record, and read back
// by the package's own reader to 1 pT; temperatures of a MagPy CDF input carried over.
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/formats/cdf_epoch.hpp"
#include "magnetometer_insitu_calibration/formats/cdf_writer.hpp"
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/formats/imagcdf_writer.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

namespace mic = magnetometer_insitu_calibration;
using mic::test::ProgramRun;
using mic::test::run_program;

namespace {

const char* kJcdf = "/usr/share/java/jcdf.jar";  // Debian package libjcdf-java (scripts/install_deps.sh)

/// CdfList -data output: per variable, the text of each record value.
std::map<std::string, std::vector<std::string>> jcdf_list(const std::string& cdf, const std::string& dir) {
  const ProgramRun r = run_program("java", std::string("-cp ") + kJcdf + " uk.ac.bristol.star.cdf.util.CdfList -data " +
                                               cdf + " > " + dir + "/jcdf.txt");
  EXPECT_EQ(r.status, 0) << r.output;
  std::map<std::string, std::vector<std::string>> out;
  std::ifstream in(dir + "/jcdf.txt");
  std::string line, variable;
  while (std::getline(in, line)) {
    if (line.compare(0, 9, "Variable ") == 0) {  // "Variable 0: GeomagneticFieldH  ---  DOUBLE (z) 0:[] T/"
      const std::size_t colon = line.find(": ");
      variable = line.substr(colon + 2, line.find(' ', colon + 2) - colon - 2);
      continue;
    }
    const std::size_t tab = line.find(":\t");  // "      12:\t21.5"
    if (variable.empty() || tab == std::string::npos) continue;
    const std::string index = line.substr(0, tab);
    if (index.find_first_not_of(' ') == std::string::npos || index.find_first_not_of(" 0123456789") != std::string::npos) continue;
    out[variable].push_back(line.substr(tab + 2));
  }
  return out;
}

}  // namespace

TEST(ExportCorrectedCdf, ImagCdfReadByJcdfHasTheValuesOfTheIagaExport) {
  std::ifstream jar(kJcdf);
  ASSERT_TRUE(jar.good()) << kJcdf << " missing: install libjcdf-java (scripts/install_deps.sh)";
  const std::string dir = mic::test::make_temp_dir("export_cdf");
  const std::string lemi = mic::test::test_data("cdf/LEMI036_1_0002_0002_2025-05-14.cdf");
  const std::string fge = mic::test::test_data("cdf/FGE_S0252_0002_0002_2025-05-14.cdf");
  ProgramRun r = run_program(CALIBRATE_RECORDS_BIN, "--reference " + lemi + " --test " + fge + " --json " + dir + "/day.json");
  ASSERT_EQ(r.status, 0) << r.output;
  r = run_program(EXPORT_CORRECTED_BIN, "--test " + fge + " --calibration " + dir + "/day.json -o " + dir + "/fge.cdf");
  ASSERT_EQ(r.status, 0) << r.output;
  r = run_program(EXPORT_CORRECTED_BIN, "--test " + fge + " --calibration " + dir + "/day.json -o " + dir + "/fge.sec");
  ASSERT_EQ(r.status, 0) << r.output;
  const mic::VectorRecord iaga = mic::read_iaga2002(dir + "/fge.sec");
  ASSERT_EQ(iaga.size(), 86400u);

  // The independent reader.
  const auto listed = jcdf_list(dir + "/fge.cdf", dir);
  ASSERT_EQ(listed.count("GeomagneticVectorTimes"), 1u) << "jcdf listed no GeomagneticVectorTimes";
  const std::vector<std::string>& times = listed.at("GeomagneticVectorTimes");
  ASSERT_EQ(times.size(), iaga.size());
  double largest = 0.0;
  for (std::size_t i = 0; i < iaga.size(); ++i) {
    // jcdf prints TT2000 as UTC "2025-05-14T00:00:00.000000000" (its own leap-second table).
    ASSERT_EQ(times[i], mic::format_iso8601(iaga.time_s[i], 9).substr(0, 29)) << i;
    for (int c = 0; c < 3; ++c) {
      const std::vector<std::string>& values = listed.at("GeomagneticField" + iaga.components[c]);
      ASSERT_EQ(values.size(), iaga.size());
      const double v = std::stod(values[i]);
      largest = std::max(largest, std::abs(v - iaga.values_nT(static_cast<Eigen::Index>(i), c)));
    }
  }
  EXPECT_LE(largest, 0.005 + 1e-9);  // the IAGA-2002 export holds these values rounded to 0.01 nT

  // The package's own reader: the corrected values to 1 pT.
  const mic::VectorRecord back = mic::read_record(dir + "/fge.cdf");
  ASSERT_EQ(back.size(), iaga.size());
  EXPECT_EQ(back.components, iaga.components);
  EXPECT_EQ(back.station, "WIC");
  for (std::size_t i = 0; i < back.size(); ++i) {
    ASSERT_EQ(back.time_s[i], iaga.time_s[i]);
    for (int c = 0; c < 3; ++c) {
      const double v = std::stod(listed.at("GeomagneticField" + iaga.components[c])[i]);
      ASSERT_NEAR(back.values_nT(static_cast<Eigen::Index>(i), c), v, 1e-3) << i;
    }
  }
  EXPECT_NE(back.header.at("Comments").find("n row 1:"), std::string::npos);  // the calibration applied
  EXPECT_EQ(back.header.at("FormatVersion"), "1.2");

  // The day as two ImagCDF files (overlapping by an hour), given in reverse order: the same export.
  const mic::VectorRecord day = mic::read_record(fge);
  for (const auto& [name, first, last] : {std::tuple<const char*, long, long>{"/fge_a.cdf", 0, 46800}, {"/fge_b.cdf", 43200, 86400}}) {
    mic::VectorRecord part = day;
    part.time_s.assign(day.time_s.begin() + first, day.time_s.begin() + last);
    part.values_nT = day.values_nT.middleRows(first, last - first);
    mic::write_imagcdf(dir + name, part);
  }
  r = run_program(EXPORT_CORRECTED_BIN, "--test " + dir + "/fge_b.cdf " + dir + "/fge_a.cdf --calibration " + dir +
                                            "/day.json -o " + dir + "/split.cdf");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("3600 samples from 2025-05-14T12:00:00.000Z to 2025-05-14T12:59:59.000Z overlap"), std::string::npos)
      << r.output;
  const mic::VectorRecord split = mic::read_record(dir + "/split.cdf");
  EXPECT_EQ(split.time_s, back.time_s);
  EXPECT_TRUE(split.values_nT == back.values_nT);
}

TEST(ExportCorrectedCdf, TemperaturesOfAMagPyInputBecomeTemperatureVariables) {
  const std::string dir = mic::test::make_temp_dir("export_cdf_t");
  const std::string lemi = mic::test::test_data("cdf/LEMI036_1_0002_0002_2025-05-14.cdf");
  // Any valid report with the LEMI as its test will do: the LEMI against the FGE.
  const std::string fge = mic::test::test_data("cdf/FGE_S0252_0002_0002_2025-05-14.cdf");
  ProgramRun r = run_program(CALIBRATE_RECORDS_BIN, "--reference " + fge + " --test " + lemi + " --intervals 1 --json " + dir + "/self.json");
  ASSERT_EQ(r.status, 0) << r.output;
  r = run_program(EXPORT_CORRECTED_BIN, "--test " + lemi + " --calibration " + dir + "/self.json --allow-flagged -o " + dir + "/lemi.cdf");
  ASSERT_EQ(r.status, 0) << r.output;
  const mic::VectorRecord original = mic::read_record(lemi);
  const auto listed = jcdf_list(dir + "/lemi.cdf", dir);
  for (int k = 0; k < 2; ++k) {
    const std::string name = "Temperature" + std::to_string(k + 1);
    ASSERT_EQ(listed.count(name), 1u) << name;
    const std::vector<std::string>& values = listed.at(name);
    ASSERT_EQ(values.size(), original.size());
    for (std::size_t i = 0; i < values.size(); i += 997) {
      EXPECT_EQ(std::stod(values[i]), original.auxiliary[static_cast<std::size_t>(k)].values[i]) << name << " " << i;
    }
    EXPECT_EQ(listed.at(name + "Times").size(), original.size());
  }
}

// The package's CDF 2.7 encoding (4-byte offsets, 64-character names, big endian, GZIP file and
// variables, CDF_EPOCH), which the reader's CDF 2 path is tested on, checked by the independent
// reader: jcdf lists the same values and times.
TEST(ExportCorrectedCdf, Cdf27FileOfTheWriterIsReadByJcdf) {
  const std::string dir = mic::test::make_temp_dir("cdf27_jcdf");
  const mic::VectorRecord lemi = mic::read_record(mic::test::test_data("cdf/LEMI036_1_0002_0002_2025-05-14.cdf"));
  const std::size_t n = 600;
  mic::CdfWriteContent content;
  content.version = 2;
  content.big_endian = true;
  content.gzip_file = content.gzip_variables = true;
  content.global = {{"DataFormat", {mic::CdfWriteEntry::of_text("MagPyCDF1.0")}}};
  mic::CdfWriteVariable epoch;
  epoch.name = "time";
  epoch.data_type = mic::kCdfEpoch;
  mic::CdfWriteVariable x;
  x.name = "x";
  for (std::size_t i = 0; i < n; ++i) {
    epoch.values.push_back((lemi.time_s[i] + mic::kCdfEpochUnixOffset_s) * 1000.0);
    x.values.push_back(lemi.values_nT(static_cast<Eigen::Index>(i), 0));
  }
  content.variables = {epoch, x};
  mic::write_cdf(dir + "/v27.cdf", content);
  const auto listed = jcdf_list(dir + "/v27.cdf", dir);
  ASSERT_EQ(listed.count("x"), 1u);
  ASSERT_EQ(listed.at("x").size(), n);
  ASSERT_EQ(listed.at("time").size(), n);
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_EQ(std::stod(listed.at("x")[i]), x.values[i]) << i;
    // jcdf prints CDF_EPOCH as "2025-05-14T00:00:00.000"
    ASSERT_EQ(listed.at("time")[i], mic::format_iso8601(lemi.time_s[i], 3).substr(0, 23)) << i;
  }
}
