// ROS layer without a master: the calibration message and YAML file, and the correction model.
#include "magnetometer_insitu_calibration/ros/calibration_message.hpp"
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"
#include "magnetometer_insitu_calibration/ros/correction_model.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <Eigen/LU>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

/// The line a file of the current format starts its version with (kCalibrationFileFormat).
const std::string kCurrentFormatLine = "format_version: " + std::to_string(mic::kCalibrationFileFormat) + "\n";

/// `text` (a file of the current format) with its version line saying `version` instead.
std::string with_format_version(std::string text, int version) {
  const std::size_t line = text.find(kCurrentFormatLine);
  if (line == std::string::npos) throw std::runtime_error("no '" + kCurrentFormatLine + "' line");
  return text.replace(line, kCurrentFormatLine.size() - 1, "format_version: " + std::to_string(version));
}

mic::MagnetometerCalibration filled_calibration() {
  std::mt19937_64 random(3);
  std::normal_distribution<double> normal;
  mic::MagnetometerCalibration c;
  c.header.stamp = ros::Time(1747191600, 123456789);
  c.header.frame_id = "reference_frame";
  c.test_name = "fge \"north\"";
  c.reference_frame_id = "reference_frame";
  c.test_frame_id = "test_frame";
  c.window_start = ros::Time(1747180800, 0);
  c.window_end = ros::Time(1747191599, 500000000);
  c.sample_period = 1.0;
  c.samples = 10800;
  c.filled_samples = 12;
  c.band_low_hz = 0.0002;
  c.band_high_hz = 0.01;
  c.harmonic_first = 3;
  c.harmonic_last = 108;
  c.gamma = 1.0;
  c.trend_column = true;
  for (auto& v : c.matrix) v = 1.0 + 1e-4 * normal(random);
  for (auto& v : c.matrix_covariance) v = 1e-12 * normal(random);
  c.covariance_cells = 23.75;
  c.interval_quantile = 2.0646;
  for (auto* array : {&c.trend_nT_per_day, &c.trend_ci95_nT_per_day, &c.scale_ratio, &c.scale_ratio_ci95,
                      &c.nonorthogonality_deg, &c.nonorthogonality_ci95_deg, &c.misalignment_deg,
                      &c.misalignment_ci95_deg, &c.axis_deviation_deg, &c.axis_deviation_ci95_deg, &c.coherence,
                      &c.residual_rms_nT, &c.offset_nT, &c.offset_ci95_nT}) {
    for (auto& v : *array) v = normal(random) / 3.0;
  }
  c.residual_rms_nT[1] = std::numeric_limits<double>::quiet_NaN();
  c.reference_mean_nT = {21512.25, -503.125, 43001.5};
  c.condition_number = 3.14159;
  c.quality = mic::MagnetometerCalibration::QUALITY_OK;
  c.quality_text = "ok";
  c.temperature_fitted = true;
  c.temperature_text = "temperature terms fitted; n at 20.125 degC (range 6.5 degC)";
  c.temperature_reference_C = 20.125;
  c.temperature_range_C = 6.5;
  for (auto* array : {&c.temperature_apparent_nT_per_C, &c.temperature_apparent_ci95_nT_per_C,
                      &c.temperature_offset_nT_per_C, &c.temperature_offset_ci95_nT_per_C,
                      &c.temperature_scale_ppm_per_C, &c.temperature_scale_ci95_ppm_per_C}) {
    for (auto& v : *array) v = normal(random);
  }
  c.accepted = true;
  c.remote_used = true;
  c.remote_text = "remote reference WNG (first-stage F 840)";
  c.remote_coherence = {0.97, 0.95, 0.81};
  c.remote_strength = 840.25;
  for (auto& v : c.pair_only_matrix) v = 1.0 + 1e-4 * normal(random);
  c.pair_difference_p_value = 0.375;
  c.pair_biased = false;
  return c;
}

std::string temp_dir() {
  std::string pattern = (std::filesystem::temp_directory_path() / "mic_ros_XXXXXX").string();
  if (mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp");
  return pattern;
}

}  // namespace

/// The table's field names, in its order (pipeline/calibration_record.hpp).
std::vector<std::string> table_names() {
  std::vector<std::string> names;
#define MIC_NAME(kind, name, since, comment) names.push_back(#name);
  MIC_CALIBRATION_FIELDS(MIC_NAME)
#undef MIC_NAME
  return names;
}

TEST(CalibrationMessage, HasTheTableFieldsInItsOrder) {
  // The message definition as compiled (msg/MagnetometerCalibration.msg): its own fields, not the
  // Header's (after the first "===" line), without constants (NAME = value) or comments.
  std::istringstream definition(ros::message_traits::Definition<mic::MagnetometerCalibration>::value());
  std::vector<std::string> fields;
  for (std::string line; std::getline(definition, line) && line.rfind("===", 0) != 0;) {
    line = line.substr(0, line.find('#'));
    std::istringstream words(line);
    std::string type, name;
    if (!(words >> type >> name) || line.find('=') != std::string::npos) continue;
    fields.push_back(name);
  }
  std::vector<std::string> expected = {"header"};
  for (const std::string& name : table_names()) expected.push_back(name);
  expected.push_back("verdicts");  // beyond the record: derived from it, not kept in the calibration file
  EXPECT_EQ(fields, expected);
}

TEST(CalibrationMessage, CarriesTheRecordFieldByField) {
  mic::CalibrationRecord r;
  r.stamp = {1747191600, 123456789};
  r.frame_id = "lemi036";
  r.test_name = "fge";
  r.window_start = {1747180800, 500000000};
  r.samples = 10800;
  r.trend_column = true;
  r.matrix[7] = 1.25;
  r.matrix_covariance[80] = 4e-12;
  r.nonorthogonality_deg = {0.1, 0.2, 0.3};
  r.quality = 4;
  r.accepted = false;
  r.temperature_scale_ppm_per_C[2] = std::numeric_limits<double>::quiet_NaN();
  const mic::MagnetometerCalibration m = mic::to_message(r);
  EXPECT_EQ(m.header.stamp, ros::Time(1747191600, 123456789));
  EXPECT_EQ(m.header.frame_id, "lemi036");
  EXPECT_EQ(m.test_name, "fge");
  EXPECT_EQ(m.window_start, ros::Time(1747180800, 500000000));
  EXPECT_EQ(m.samples, 10800u);
  EXPECT_TRUE(m.trend_column);
  EXPECT_EQ(m.matrix[7], 1.25);
  EXPECT_EQ(m.matrix_covariance[80], 4e-12);
  EXPECT_EQ(m.nonorthogonality_deg[2], 0.3);
  EXPECT_EQ(m.quality, mic::MagnetometerCalibration::QUALITY_LOW_COHERENCE);
  EXPECT_FALSE(m.accepted);
  EXPECT_TRUE(std::isnan(m.temperature_scale_ppm_per_C[2]));
  r.window_end = {-5, 0};  // before 1970: no ROS time
  EXPECT_THROW(mic::to_message(r), std::out_of_range);
}

TEST(CalibrationYaml, EveryFieldIsRequiredByTheFormatsThatHaveIt) {
  // For each format: a file without the fields added after it loads; a file of the format
  // without one of its own fields is refused, naming the field.
  const std::string text = mic::calibration_to_yaml(filled_calibration(), "/x");
  auto without = [](std::string t, const std::string& key) {
    const std::size_t line = t.find("\n" + key + ": ");
    EXPECT_NE(line, std::string::npos) << key;
    if (line != std::string::npos) t.erase(line + 1, t.find('\n', line + 1) - line);
    return t;
  };
  struct Field {
    std::string name;
    int since;
  };
  std::vector<Field> table;
#define MIC_FIELD(kind, name, since, comment) table.push_back({#name, since});
  MIC_CALIBRATION_FIELDS(MIC_FIELD)
#undef MIC_FIELD
  for (int version = 1; version <= mic::kCalibrationFileFormat; ++version) {
    std::string old = text;
    for (const Field& f : table) {
      if (f.since > version) old = without(old, f.name);
    }
    old = with_format_version(old, version);
    EXPECT_NO_THROW(mic::calibration_from_yaml(old, "old.yaml")) << "format " << version;
    for (const Field& f : table) {
      if (f.since > version) continue;
      try {
        mic::calibration_from_yaml(without(old, f.name), "cut.yaml");
        ADD_FAILURE() << "format " << version << " without " << f.name << " loaded";
      } catch (const mic::CalibrationFileError& e) {
        EXPECT_NE(std::string(e.what()).find("cut.yaml: field '" + f.name + "' is missing"), std::string::npos)
            << e.what();
      }
    }
  }
}

TEST(CalibrationYaml, Format1LoadsAsPlainWithoutDelayOrOffset) {
  std::string text = mic::calibration_to_yaml(filled_calibration(), "/x");
  for (const char* key : {"method", "band_used_low_hz", "band_used_high_hz", "delay_s", "delay_ci95_s", "offset_nT",
                          "offset_ci95_nT", "reference_mean_nT", "covariance_cells", "interval_quantile"}) {
    const std::size_t line = text.find(std::string("\n") + key + ": ");
    ASSERT_NE(line, std::string::npos) << key;
    text.erase(line + 1, text.find('\n', line + 1) - line);
  }
  for (std::size_t line = text.find("\ntemperature_"); line != std::string::npos; line = text.find("\ntemperature_")) {
    text.erase(line + 1, text.find('\n', line + 1) - line);
  }
  text = with_format_version(text, 1);
  const mic::MagnetometerCalibration c = mic::calibration_from_yaml(text, "v1.yaml");
  EXPECT_EQ(c.method, "plain");
  EXPECT_EQ(c.band_used_low_hz, c.band_low_hz);
  EXPECT_EQ(c.band_used_high_hz, c.band_high_hz);
  EXPECT_TRUE(std::isnan(c.delay_s));
  EXPECT_EQ(c.offset_nT[0], 0.0);
  EXPECT_TRUE(std::isnan(c.offset_ci95_nT[0]));
  EXPECT_TRUE(std::isinf(c.covariance_cells));
  EXPECT_EQ(c.temperature_text, "calibration file format 1 has no temperature terms");
}

TEST(CalibrationYaml, RoundTripIsExact) {
  const mic::MagnetometerCalibration c = filled_calibration();
  const std::string text = mic::calibration_to_yaml(c, "/calibration_fge");
  const mic::MagnetometerCalibration back = mic::calibration_from_yaml(text, "memory");
  std::string difference;
  EXPECT_TRUE(mic::calibrations_equal(c, back, &difference)) << difference << "\n" << text;
  mic::MagnetometerCalibration other = back;
  other.matrix[4] = std::nextafter(other.matrix[4], 2.0);
  EXPECT_FALSE(mic::calibrations_equal(c, other, &difference));
  EXPECT_EQ(difference, "matrix");
}

TEST(CalibrationYaml, Format2LoadsWithoutReferenceMean) {
  // A format-2 file (before reference_mean_nT): loads, with the mean 0 (the whole-field
  // propagation correction_node used before); a format it does not know is refused.
  std::string text = mic::calibration_to_yaml(filled_calibration(), "/x");
  const std::size_t version = text.find(kCurrentFormatLine);
  ASSERT_NE(version, std::string::npos) << text;
  const std::size_t mean_line = text.find("reference_mean_nT: ");
  ASSERT_NE(mean_line, std::string::npos);
  std::string old = text;
  old.erase(mean_line, old.find('\n', mean_line) + 1 - mean_line);
  old = with_format_version(old, 2);
  const mic::MagnetometerCalibration loaded = mic::calibration_from_yaml(old, "old.yaml");
  for (double v : loaded.reference_mean_nT) EXPECT_EQ(v, 0.0);
  EXPECT_EQ(loaded.offset_nT, filled_calibration().offset_nT);
  // Format 5 without the field is incomplete.
  std::string cut = text;
  cut.erase(mean_line, cut.find('\n', mean_line) + 1 - mean_line);
  EXPECT_THROW(mic::calibration_from_yaml(cut, "cut.yaml"), mic::CalibrationFileError);
  std::string future = text;
  future = with_format_version(future, mic::kCalibrationFileFormat + 1);
  EXPECT_THROW(mic::calibration_from_yaml(future, "future.yaml"), mic::CalibrationFileError);
}

TEST(CalibrationYaml, Format3LoadsWithoutTemperatureTerms) {
  // A format-3 file (before the temperature terms): loads, not fitted, NaN coefficients, a text
  // naming the format; a format-4 file without one of the temperature lines is incomplete.
  const mic::MagnetometerCalibration c = filled_calibration();
  const std::string text = mic::calibration_to_yaml(c, "/x");
  std::string old = text;
  for (std::size_t line = old.find("\ntemperature_"); line != std::string::npos; line = old.find("\ntemperature_")) {
    old.erase(line + 1, old.find('\n', line + 1) - line);
  }
  ASSERT_EQ(old.find("temperature"), std::string::npos) << old;
  const std::size_t version = old.find(kCurrentFormatLine);
  ASSERT_NE(version, std::string::npos);
  old = with_format_version(old, 3);
  const mic::MagnetometerCalibration loaded = mic::calibration_from_yaml(old, "v3.yaml");
  EXPECT_FALSE(loaded.temperature_fitted);
  EXPECT_EQ(loaded.temperature_text, "calibration file format 3 has no temperature terms");
  EXPECT_TRUE(std::isnan(loaded.temperature_reference_C));
  for (double v : loaded.temperature_apparent_nT_per_C) EXPECT_TRUE(std::isnan(v));
  for (double v : loaded.temperature_scale_ppm_per_C) EXPECT_TRUE(std::isnan(v));
  EXPECT_EQ(loaded.reference_mean_nT, c.reference_mean_nT);
  EXPECT_EQ(loaded.matrix, c.matrix);
  EXPECT_TRUE(loaded.accepted);
  std::string cut = text;
  const std::size_t scale = cut.find("temperature_scale_ppm_per_C: ");
  ASSERT_NE(scale, std::string::npos);
  cut.erase(scale, cut.find('\n', scale) + 1 - scale);
  try {
    mic::calibration_from_yaml(cut, "cut.yaml");
    ADD_FAILURE() << "a format-5 file without temperature_scale_ppm_per_C loaded";
  } catch (const mic::CalibrationFileError& e) {
    EXPECT_NE(std::string(e.what()).find("cut.yaml: field 'temperature_scale_ppm_per_C' is missing"), std::string::npos)
        << e.what();
  }
  // A difference in a temperature field is seen.
  mic::MagnetometerCalibration other = c;
  other.temperature_offset_nT_per_C[2] += 1e-9;
  std::string difference;
  EXPECT_FALSE(mic::calibrations_equal(c, other, &difference));
  EXPECT_EQ(difference, "temperature_offset_nT_per_C");
}

TEST(CalibrationYaml, Format4LoadsAsACovarianceTakenAsKnown) {
  // A format-4 file (before the covariance's cells and the intervals' quantile): loads with the
  // covariance taken as known (infinite cells) and its intervals' 1.96; a format-5 file without
  // either line is incomplete, and impossible values are refused naming the field.
  const std::string text = mic::calibration_to_yaml(filled_calibration(), "/x");
  EXPECT_NE(text.find("covariance_cells: 23.75  #"), std::string::npos) << text;
  auto without = [](std::string t, const std::string& key) {
    const std::size_t line = t.find("\n" + key + ": ");
    if (line != std::string::npos) t.erase(line + 1, t.find('\n', line + 1) - line);
    return t;
  };
  std::string old = without(without(text, "covariance_cells"), "interval_quantile");
  ASSERT_EQ(old.find("interval_quantile"), std::string::npos);
  const std::size_t version = old.find(kCurrentFormatLine);
  ASSERT_NE(version, std::string::npos);
  old = with_format_version(old, 4);
  const mic::MagnetometerCalibration loaded = mic::calibration_from_yaml(old, "v4.yaml");
  EXPECT_TRUE(std::isinf(loaded.covariance_cells));
  EXPECT_NEAR(loaded.interval_quantile, 1.959964, 1e-6);
  EXPECT_EQ(loaded.matrix_covariance, filled_calibration().matrix_covariance);
  for (const char* key : {"covariance_cells", "interval_quantile"}) {
    try {
      mic::calibration_from_yaml(without(text, key), "cut.yaml");
      ADD_FAILURE() << "a format-5 file without " << key << " loaded";
    } catch (const mic::CalibrationFileError& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("cut.yaml: field '") + key + "' is missing"), std::string::npos)
          << e.what();
    }
  }
  std::string known = text;
  known.replace(known.find("covariance_cells: 23.75"), 23, "covariance_cells: .inf");
  EXPECT_TRUE(std::isinf(mic::calibration_from_yaml(known, "known.yaml").covariance_cells));
  for (const auto& bad : {std::make_pair("covariance_cells: 23.75", "covariance_cells: 0"),
                          std::make_pair("interval_quantile: 2.0646", "interval_quantile: 1.5")}) {
    std::string wrong = text;
    wrong.replace(wrong.find(bad.first), std::string(bad.first).size(), bad.second);
    try {
      mic::calibration_from_yaml(wrong, "bad.yaml");
      ADD_FAILURE() << bad.second << " loaded";
    } catch (const mic::CalibrationFileError& e) {
      const std::string key = std::string(bad.second).substr(0, std::string(bad.second).find(':'));
      EXPECT_NE(std::string(e.what()).find("bad.yaml: field '" + key + "'"), std::string::npos) << e.what();
    }
  }
}

TEST(CalibrationYaml, EveryTruncationIsRefused) {
  const std::string text = mic::calibration_to_yaml(filled_calibration(), "/calibration_fge");
  // Complete from the end of the last field's value (its comment may be cut).
  const std::size_t last_line = text.rfind('\n', text.size() - 2) + 1;
  const std::size_t complete = std::min(text.find("  #", last_line), text.size() - 1);
  ASSERT_GT(complete, last_line) << text;
  for (std::size_t length = 0; length < complete; ++length) {
    EXPECT_THROW(mic::calibration_from_yaml(text.substr(0, length), "cut"), mic::CalibrationFileError)
        << "a file cut after " << length << " bytes was accepted";
  }
}

TEST(CalibrationYaml, ErrorsNameTheFieldAndFile) {
  std::string text = mic::calibration_to_yaml(filled_calibration(), "/x");
  const std::size_t at = text.find("matrix: [");
  text.replace(at, 9, "matrix: [oops, ");
  try {
    mic::calibration_from_yaml(text, "/some/file.yaml");
    FAIL() << "accepted a bad matrix";
  } catch (const mic::CalibrationFileError& e) {
    EXPECT_NE(std::string(e.what()).find("/some/file.yaml"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'matrix'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(mic::calibration_from_yaml("{a: [1, 2", "f"), mic::CalibrationFileError);
  EXPECT_THROW(mic::calibration_from_yaml("- just\n- a list\n", "f"), mic::CalibrationFileError);
  EXPECT_THROW(mic::load_calibration_file("/nonexistent/dir/calibration.yaml"), mic::CalibrationFileError);
}

TEST(CalibrationYaml, AtomicWriteReplacesAndLeavesNoTemporary) {
  const std::string dir = temp_dir();
  const std::string path = dir + "/calibration.yaml";
  mic::MagnetometerCalibration c = filled_calibration();
  mic::write_file_atomically(path, mic::calibration_to_yaml(c, "/a"));
  c.matrix[0] = 2.0;
  mic::write_file_atomically(path, mic::calibration_to_yaml(c, "/a"));
  EXPECT_TRUE(mic::calibrations_equal(mic::load_calibration_file(path), c));
  std::size_t files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    ++files;
    EXPECT_EQ(entry.path().filename(), "calibration.yaml");
  }
  EXPECT_EQ(files, 1u);
  EXPECT_THROW(mic::write_file_atomically(dir + "/missing/calibration.yaml", "x"), std::runtime_error);
  std::filesystem::remove_all(dir);
}

// ---------------------------------------------------------------------------------------------

// ---------------------------------------------------------------------------------------------

TEST(CorrectionModel, InvertsTheCalibrationAndPropagatesCovariance) {
  mic::SimulationSettings s;
  const Eigen::Matrix3d n = s.n_true();
  mic::Matrix9d cov = mic::Matrix9d::Identity() * 1e-10;
  cov(0, 4) = cov(4, 0) = 0.5e-10;
  const mic::CorrectionModel model(n, cov, 100.0);
  const Eigen::Vector3d field(21500.0, 500.0, 43000.0);  // reference frame
  const Eigen::Vector3d test = n.transpose() * field;    // T = R n, rows -> t = n^T r
  EXPECT_LT((model.correct(test) - field).norm(), 1e-9);
  // Covariance of the test noise: n^-T C n^-1.
  const Eigen::Matrix3d c_t = Eigen::Vector3d(1e-4, 2e-4, 3e-4).asDiagonal();
  const Eigen::Matrix3d n_inv = n.inverse();
  EXPECT_LT((model.corrected_covariance(c_t, field, false) - n_inv.transpose() * c_t * n_inv).norm(), 1e-15);
  // Calibration term against numeric derivatives of r(n) = n^-T t.
  Eigen::Matrix<double, 3, 9> jacobian;
  for (int k = 0; k < 9; ++k) {
    Eigen::Matrix3d plus = n, minus = n;
    plus(k / 3, k % 3) += 1e-7;
    minus(k / 3, k % 3) -= 1e-7;
    jacobian.col(k) = (plus.inverse().transpose() * test - minus.inverse().transpose() * test) / 2e-7;
  }
  const Eigen::Matrix3d expected = n_inv.transpose() * c_t * n_inv + jacobian * cov * jacobian.transpose();
  const Eigen::Matrix3d got = model.corrected_covariance(c_t, field, true);
  EXPECT_LT((got - expected).norm(), 1e-6 * expected.norm()) << got << "\n" << expected;
}

TEST(CorrectionModel, OffsetAbsorbsTheMatrixErrorAtTheWindowMean) {
  // The calibration's offset was estimated with n: d(n) = mean_t - n^T m (m = mean(R) of the
  // window). The corrected reading r(n) = n^-T (t - d(n)) then depends on n through both terms;
  // its numeric Jacobian must match the model's (r - m) form, and at the window mean field the
  // calibration adds no uncertainty at all.
  mic::SimulationSettings s;
  const Eigen::Matrix3d n = s.n_true();
  mic::Matrix9d cov = mic::Matrix9d::Identity() * 1e-10;
  cov(1, 5) = cov(5, 1) = -0.3e-10;
  const Eigen::Vector3d m(21480.0, 512.0, 43020.0);              // reference frame, nT
  const Eigen::Vector3d d_true(-37.0, 12.5, 80.0);               // test frame, nT
  const Eigen::Vector3d mean_t = n.transpose() * m + d_true;    // test frame, nT
  const Eigen::Vector3d d = mean_t - n.transpose() * m;
  const mic::CorrectionModel model(n, cov, 100.0, d, m);
  const Eigen::Vector3d field = m + Eigen::Vector3d(25.0, -40.0, 12.0);  // r, 50 nT from the mean
  const Eigen::Vector3d test = n.transpose() * field + d;
  ASSERT_LT((model.correct(test) - field).norm(), 1e-9);
  auto corrected_with = [&](const Eigen::Matrix3d& n_other) {
    const Eigen::Vector3d d_other = mean_t - n_other.transpose() * m;
    return Eigen::Vector3d(n_other.inverse().transpose() * (test - d_other));
  };
  Eigen::Matrix<double, 3, 9> jacobian;
  for (int k = 0; k < 9; ++k) {
    Eigen::Matrix3d plus = n, minus = n;
    plus(k / 3, k % 3) += 1e-7;
    minus(k / 3, k % 3) -= 1e-7;
    jacobian.col(k) = (corrected_with(plus) - corrected_with(minus)) / 2e-7;
  }
  const Eigen::Matrix3d zero = Eigen::Matrix3d::Zero();
  const Eigen::Matrix3d expected = jacobian * cov * jacobian.transpose();
  const Eigen::Matrix3d got = model.corrected_covariance(zero, field, true);
  EXPECT_LT((got - expected).norm(), 1e-5 * expected.norm()) << got << "\n" << expected;
  // Whole-field propagation (no anchor) states ~1000x the standard deviation here.
  const mic::CorrectionModel whole_field(n, cov, 100.0, d);
  EXPECT_GT(whole_field.corrected_covariance(zero, field, true).trace(), 1e5 * got.trace());
  EXPECT_LT(model.corrected_covariance(zero, m, true).norm(), 1e-20);
  EXPECT_THROW(mic::CorrectionModel(n, cov, 100.0, d, Eigen::Vector3d::Constant(std::nan(""))),
               std::invalid_argument);
}

TEST(CorrectionModel, RefusesUnusableMatrices) {
  const mic::Matrix9d cov = mic::Matrix9d::Zero();
  Eigen::Matrix3d singular = Eigen::Matrix3d::Identity();
  singular(2, 2) = 0.0;
  EXPECT_THROW(mic::CorrectionModel(singular, cov, 100.0), std::invalid_argument);
  Eigen::Matrix3d bad = Eigen::Matrix3d::Identity();
  bad(0, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(mic::CorrectionModel(bad, cov, 100.0), std::invalid_argument);
  Eigen::Matrix3d stretched = Eigen::Matrix3d::Identity();
  stretched(0, 0) = 1000.0;
  EXPECT_THROW(mic::CorrectionModel(stretched, cov, 100.0), std::invalid_argument);
  mic::Matrix9d nan_cov = cov;
  nan_cov(3, 3) = std::numeric_limits<double>::infinity();
  EXPECT_THROW(mic::CorrectionModel(Eigen::Matrix3d::Identity(), nan_cov, 100.0), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------

