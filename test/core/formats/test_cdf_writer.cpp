// CDF writer and ImagCDF layout: read back by the package's reader (both encodings, fill values,
// temperatures), and a record inside a leap second in a written file.
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/cdf_epoch.hpp"
#include "magnetometer_insitu_calibration/formats/cdf_records.hpp"
#include "magnetometer_insitu_calibration/formats/cdf_writer.hpp"
#include "magnetometer_insitu_calibration/formats/imagcdf_writer.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

namespace mic = magnetometer_insitu_calibration;
using mic::test::contains;

namespace {

void expect_same_record(const mic::VectorRecord& a, const mic::VectorRecord& b) {
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(a.components, b.components);
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a.time_s[i], b.time_s[i]) << i;
    for (int c = 0; c < 3; ++c) {
      const double x = a.values_nT(static_cast<Eigen::Index>(i), c), y = b.values_nT(static_cast<Eigen::Index>(i), c);
      ASSERT_EQ(std::isnan(x), std::isnan(y)) << i;
      if (!std::isnan(x)) ASSERT_NEAR(x, y, 1e-3) << i;  // 1 pT
    }
  }
}

}  // namespace

TEST(CdfWriter, ImagCdfReadsBackInBothEncodingsWithFillsAndTemperatures) {
  const std::string dir = mic::test::make_temp_dir("imagcdf");
  mic::VectorRecord lemi = mic::read_record(mic::test::test_data("cdf/LEMI036_1_0002_0002_2025-05-14.cdf"));
  lemi.values_nT(10, 1) = std::numeric_limits<double>::quiet_NaN();  // missing -> FILLVAL 99999 -> NaN
  lemi.auxiliary[0].values[20] = std::numeric_limits<double>::quiet_NaN();
  for (const bool big : {false, true}) {
    SCOPED_TRACE(big ? "big endian" : "little endian");
    mic::ImagCdfWriteOptions options;
    options.big_endian = big;
    options.comments = {"first paragraph", "second"};
    options.latitude = 47.93;
    const std::string path = dir + (big ? "/big.cdf" : "/little.cdf");
    mic::write_imagcdf(path, lemi, options);
    ASSERT_EQ(mic::detect_record_format(path), mic::RecordFormat::kCdf);
    const mic::CdfFile file = mic::CdfFile::open(path);
    EXPECT_EQ(file.little_endian(), !big);
    EXPECT_EQ(file.global_text("FormatVersion"), "1.2");
    EXPECT_EQ(file.global_text("ElementsRecorded"), "HEZ");
    EXPECT_EQ(file.global_text("Comments"), "first paragraph\nsecond");
    EXPECT_EQ(file.global_text("Latitude"), "47.93");
    EXPECT_EQ(file.global_text("Longitude"), "15.865");  // MagPy's StationLongitude
    EXPECT_EQ(file.global_text("Elevation"), "1089");     // MagPy's StationElevation
    ASSERT_NE(file.find("GeomagneticFieldE"), nullptr);
    EXPECT_EQ(file.find("GeomagneticFieldE")->attributes.at("DEPEND_0").text, "GeomagneticVectorTimes");
    EXPECT_EQ(file.find("GeomagneticFieldE")->attributes.at("FILLVAL").numbers, std::vector<double>{99999.0});
    const mic::VectorRecord back = mic::cdf_to_vector_record(file);
    EXPECT_EQ(back.header.at("cdf_layout"), "ImagCDF");
    EXPECT_EQ(back.station, "WIC");
    expect_same_record(lemi, back);
    ASSERT_EQ(back.auxiliary.size(), 2u);
    EXPECT_EQ(back.auxiliary[0].name, "Temperature1");
    EXPECT_EQ(back.auxiliary[0].description, "T_sensor");
    EXPECT_EQ(back.auxiliary[1].description, "T_elec");
    EXPECT_TRUE(std::isnan(back.auxiliary[0].values[20]));
    EXPECT_EQ(back.auxiliary[0].values[21], lemi.auxiliary[0].values[21]);
    EXPECT_EQ(back.auxiliary[1].values, lemi.auxiliary[1].values);
  }
}

TEST(CdfWriter, RecordInsideALeapSecondIsDroppedAndCounted) {
  // ImagCDF layout by hand: 2016-12-31T23:59:58, 59, 60 (the leap second), 2017-01-01T00:00:00, 01.
  const std::int64_t midnight = mic::unix_to_tt2000(1483228800.0);
  mic::CdfWriteContent content;
  content.global = {{"ElementsRecorded", {mic::CdfWriteEntry::of_text("XYZ")}}};
  for (const char* e : {"X", "Y", "Z"}) {
    mic::CdfWriteVariable v;
    v.name = std::string("GeomagneticField") + e;
    v.values = {1, 2, 3, 4, 5};
    v.attributes = {{"DEPEND_0", mic::CdfWriteEntry::of_text("DataTimes")}};
    content.variables.push_back(v);
  }
  mic::CdfWriteVariable times;
  times.name = "DataTimes";
  times.data_type = mic::kCdfTimeTt2000;
  const std::int64_t s = 1000000000;
  times.times = {midnight - 3 * s, midnight - 2 * s, midnight - s, midnight, midnight + s};
  content.variables.push_back(times);
  const mic::VectorRecord r = mic::cdf_to_vector_record(mic::CdfFile::parse(mic::encode_cdf(content), "leap.cdf"));
  ASSERT_EQ(r.size(), 4u);
  EXPECT_EQ(r.time_s, (std::vector<double>{1483228798.0, 1483228799.0, 1483228800.0, 1483228801.0}));
  EXPECT_EQ(r.values_nT(1, 0), 2.0);
  EXPECT_EQ(r.values_nT(2, 0), 4.0);  // the value stamped 23:59:60 is the one dropped
  EXPECT_EQ(r.header.at("cdf_records_dropped"), "1");
}

TEST(CdfWriter, RefusesWhatImagCdfCannotHold) {
  const std::string dir = mic::test::make_temp_dir("imagcdf_bad");
  mic::VectorRecord r;
  r.time_s = {1747180800.0, 1747180801.0};
  r.values_nT = mic::Readings::Zero(2, 3);
  r.components = {"X1", "Y", "Z"};
  auto error = [&](const mic::VectorRecord& record) {
    try {
      mic::write_imagcdf(dir + "/bad.cdf", record);
    } catch (const mic::InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_TRUE(contains(error(r), "component 'X1' is not a one-letter element code")) << error(r);
  r.components = {"X", "Y", "Z"};
  r.values_nT(1, 2) = 80000.0;
  EXPECT_TRUE(contains(error(r), "outside VALIDMIN..VALIDMAX")) << error(r);
  r.values_nT(1, 2) = 0.0;
  r.time_s = {0.0, 1.0};
  EXPECT_TRUE(contains(error(r), "before 1972")) << error(r);
  EXPECT_TRUE(contains(error(mic::VectorRecord()), "no samples")) << error(mic::VectorRecord());
}

TEST(CdfWriter, MagPyLayoutWithFileAndVariableCompressionReadsBack) {
  // The MagPy CDF layout written with both GZIP levels, as MagPy's files are.
  const mic::VectorRecord lemi = mic::read_record(mic::test::test_data("cdf/LEMI036_1_0002_0002_2025-05-14.cdf"));
  mic::CdfWriteContent content;
  content.gzip_file = true;
  content.gzip_variables = true;
  content.global = {{"DataFormat", {mic::CdfWriteEntry::of_text("MagPyCDF1.2")}},
                    {"DataComponents", {mic::CdfWriteEntry::of_text("HEZ")}},
                    {"StationIAGAcode", {mic::CdfWriteEntry::of_text("WIC")}}};
  mic::CdfWriteVariable epoch;
  epoch.name = "Epoch";
  epoch.data_type = mic::kCdfTimeTt2000;
  for (double t : lemi.time_s) epoch.times.push_back(mic::unix_to_tt2000(t));
  content.variables.push_back(epoch);
  for (int c = 0; c < 3; ++c) {
    mic::CdfWriteVariable v;
    v.name = std::string(1, "xyz"[c]);
    for (std::size_t i = 0; i < lemi.size(); ++i) v.values.push_back(lemi.values_nT(static_cast<Eigen::Index>(i), c));
    content.variables.push_back(v);
  }
  for (const char* t : {"t1", "t2"}) {
    mic::CdfWriteVariable v;
    v.name = t;
    v.values = lemi.auxiliary[t[1] == '1' ? 0 : 1].values;
    content.variables.push_back(v);
  }
  const std::vector<std::uint8_t> bytes = mic::encode_cdf(content);
  ASSERT_EQ(bytes[4], 0xCC);  // whole-file compressed
  const mic::CdfFile file = mic::CdfFile::parse(bytes, "magpy.cdf");
  EXPECT_TRUE(file.file_compressed());
  EXPECT_TRUE(file.find("x")->compressed);
  const mic::VectorRecord back = mic::cdf_to_vector_record(file);
  EXPECT_EQ(back.header.at("cdf_layout"), "MagPy CDF");
  expect_same_record(lemi, back);
  ASSERT_EQ(back.auxiliary.size(), 2u);
  EXPECT_EQ(back.auxiliary[1].values, lemi.auxiliary[1].values);
}

TEST(CdfWriter, ImagCdfWithAnAngleElementIsRefusedByName) {
  // HDZ: D is in degrees of arc, not a field component the calibration can use.
  mic::CdfWriteContent content;
  content.global = {{"ElementsRecorded", {mic::CdfWriteEntry::of_text("HDZF")}}};
  for (const char* e : {"H", "D", "Z", "F"}) {
    mic::CdfWriteVariable v;
    v.name = std::string("GeomagneticField") + e;
    v.values = {1, 2};
    v.attributes = {{"DEPEND_0", mic::CdfWriteEntry::of_text("GeomagneticVectorTimes")}};
    content.variables.push_back(v);
  }
  mic::CdfWriteVariable times;
  times.name = "GeomagneticVectorTimes";
  times.data_type = mic::kCdfTimeTt2000;
  times.times = {mic::unix_to_tt2000(1747180800.0), mic::unix_to_tt2000(1747180801.0)};
  content.variables.push_back(times);
  try {
    mic::cdf_to_vector_record(mic::CdfFile::parse(mic::encode_cdf(content), "hdz.cdf"));
    FAIL() << "an HDZ file was read";
  } catch (const mic::InputError& e) {
    EXPECT_TRUE(contains(e.what(), "hdz.cdf: ImagCDF: element D of ElementsRecorded 'HDZF' is an angle")) << e.what();
  }
}

/// The MagPy layout as CDF 2.7 (4-byte offsets, 64-character names), big endian, both GZIP
/// levels, CDF_EPOCH times (milliseconds since year 0), for the first `n` seconds of the LEMI day.
static std::vector<std::uint8_t> magpy_cdf27(const mic::VectorRecord& lemi, std::size_t n) {
  mic::CdfWriteContent content;
  content.version = 2;
  content.big_endian = true;
  content.gzip_file = content.gzip_variables = true;
  content.global = {{"DataFormat", {mic::CdfWriteEntry::of_text("MagPyCDF1.0")}},
                    {"DataComponents", {mic::CdfWriteEntry::of_text("HEZ")}}};
  mic::CdfWriteVariable epoch;
  epoch.name = "time";
  epoch.data_type = mic::kCdfEpoch;
  for (std::size_t i = 0; i < n; ++i) epoch.values.push_back((lemi.time_s[i] + mic::kCdfEpochUnixOffset_s) * 1000.0);
  content.variables.push_back(epoch);
  for (int c = 0; c < 3; ++c) {
    mic::CdfWriteVariable v;
    v.name = std::string(1, "xyz"[c]);
    for (std::size_t i = 0; i < n; ++i) v.values.push_back(lemi.values_nT(static_cast<Eigen::Index>(i), c));
    v.attributes = {{"DEPEND_0", mic::CdfWriteEntry::of_text("time")}};
    content.variables.push_back(v);
  }
  return mic::encode_cdf(content);
}

TEST(CdfWriter, Cdf27BigEndianWithEpochTimesReadsBack) {
  const mic::VectorRecord lemi = mic::read_record(mic::test::test_data("cdf/LEMI036_1_0002_0002_2025-05-14.cdf"));
  const std::vector<std::uint8_t> bytes = magpy_cdf27(lemi, 3600);
  ASSERT_EQ(bytes[1], 0xF2);  // magic 0xCDF26002
  const mic::CdfFile file = mic::CdfFile::parse(bytes, "v27.cdf");
  EXPECT_EQ(file.version(), 2);
  EXPECT_EQ(file.release(), 7);
  EXPECT_FALSE(file.little_endian());
  const mic::VectorRecord back = mic::cdf_to_vector_record(file);
  ASSERT_EQ(back.size(), 3600u);
  for (std::size_t i = 0; i < back.size(); ++i) {
    ASSERT_EQ(back.time_s[i], lemi.time_s[i]);
    for (int c = 0; c < 3; ++c) {
      ASSERT_EQ(back.values_nT(static_cast<Eigen::Index>(i), c), lemi.values_nT(static_cast<Eigen::Index>(i), c));
    }
  }
}
