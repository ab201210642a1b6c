// ROS layer without a master: the calibration YAML file, the live sliding window, the window
// estimate with its gap flags, and the correction model.
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"
#include "magnetometer_insitu_calibration/ros/correction_model.hpp"
#include "magnetometer_insitu_calibration/ros/live_window.hpp"
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

namespace mic = magnetometer_insitu_calibration;

namespace {

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
  return c;
}

std::string temp_dir() {
  std::string pattern = (std::filesystem::temp_directory_path() / "mic_ros_XXXXXX").string();
  if (mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp");
  return pattern;
}

}  // namespace

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
  const std::size_t version = text.find("format_version: 5\n");
  ASSERT_NE(version, std::string::npos) << text;
  const std::size_t mean_line = text.find("reference_mean_nT: ");
  ASSERT_NE(mean_line, std::string::npos);
  std::string old = text;
  old.erase(mean_line, old.find('\n', mean_line) + 1 - mean_line);
  old.replace(version, 17, "format_version: 2");
  const mic::MagnetometerCalibration loaded = mic::calibration_from_yaml(old, "old.yaml");
  for (double v : loaded.reference_mean_nT) EXPECT_EQ(v, 0.0);
  EXPECT_EQ(loaded.offset_nT, filled_calibration().offset_nT);
  // Format 5 without the field is incomplete.
  std::string cut = text;
  cut.erase(mean_line, cut.find('\n', mean_line) + 1 - mean_line);
  EXPECT_THROW(mic::calibration_from_yaml(cut, "cut.yaml"), mic::CalibrationFileError);
  std::string future = text;
  future.replace(version, 17, "format_version: 6");
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
  const std::size_t version = old.find("format_version: 5\n");
  ASSERT_NE(version, std::string::npos);
  old.replace(version, 17, "format_version: 3");
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
  const std::size_t version = old.find("format_version: 5\n");
  ASSERT_NE(version, std::string::npos);
  old.replace(version, 17, "format_version: 4");
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
  const std::size_t complete = text.find("accepted: true") + std::string("accepted: true").size();
  ASSERT_NE(complete, std::string::npos);
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

TEST(SlidingWindowBuffer, WindowsAlignedOnStepAndComplete) {
  mic::SlidingWindowBuffer buffer(100.0, 30.0, 1.0);
  std::vector<mic::WindowData> windows;
  const double t0 = 1000.0 + 7.0;  // not on a step boundary: the first window starts at 1020
  for (int k = 0; k < 300; ++k) {
    for (auto& w : buffer.push(t0 + k, Eigen::Vector3d::Constant(k), Eigen::Vector3d::Constant(-k))) {
      windows.push_back(std::move(w));
    }
  }
  ASSERT_GE(windows.size(), 6u);
  for (std::size_t i = 0; i < windows.size(); ++i) {
    EXPECT_DOUBLE_EQ(windows[i].start_s, 1020.0 + 30.0 * i);
    EXPECT_EQ(windows[i].expected_samples, 100u);
    ASSERT_EQ(windows[i].paired.size(), 100u);
    EXPECT_DOUBLE_EQ(windows[i].paired.time_s.front(), windows[i].start_s);
    EXPECT_DOUBLE_EQ(windows[i].paired.time_s.back(), windows[i].end_s());
    EXPECT_DOUBLE_EQ(windows[i].paired.test_nT(0, 0), -(windows[i].start_s - t0));
  }
  EXPECT_LE(buffer.buffered(), 101u);
  // Out of order and repeated stamps are ignored.
  EXPECT_TRUE(buffer.push(t0 + 10, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()).empty());
  EXPECT_EQ(buffer.out_of_order(), 1u);
}

TEST(SlidingWindowBuffer, JumpSkipsEmptyWindowsAndEmitsPartialOnes) {
  mic::SlidingWindowBuffer buffer(100.0, 50.0, 1.0);
  std::vector<mic::WindowData> windows;
  auto push = [&](double t) {
    for (auto& w : buffer.push(t, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero())) windows.push_back(std::move(w));
  };
  for (int k = 0; k < 120; ++k) push(k);        // 0..119
  for (int k = 0; k < 1000; ++k) push(1.0e6 + k);  // a jump of ~11.6 days
  // Before the jump: [0,100) complete; [50,150) and [100,200) partial; after: [1e6, 1e6+100) ...
  ASSERT_GE(windows.size(), 4u);
  EXPECT_DOUBLE_EQ(windows[0].start_s, 0.0);
  EXPECT_EQ(windows[1].paired.size(), 70u);
  EXPECT_EQ(windows[2].paired.size(), 20u);
  for (std::size_t i = 3; i < windows.size(); ++i) EXPECT_GE(windows[i].start_s, 1.0e6 - 100.0);
  EXPECT_GT(buffer.windows_skipped_empty(), 10000u);
}

// ---------------------------------------------------------------------------------------------

namespace {

mic::WindowData simulated_window(double duration_s, std::uint64_t seed, mic::SimulatedPair* pair_out = nullptr) {
  mic::SimulationSettings s;
  s.duration_s = duration_s;
  s.seed = seed;
  mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::WindowData w;
  w.start_s = pair.reference.time_s.front();
  w.period_s = 1.0;
  w.expected_samples = pair.reference.size();
  w.paired.time_s = pair.reference.time_s;
  w.paired.reference_nT = pair.reference.values_nT;
  w.paired.test_nT = pair.test.values_nT;
  if (pair_out != nullptr) *pair_out = pair;
  return w;
}

mic::WindowData without_rows(const mic::WindowData& w, std::size_t first, std::size_t count) {
  mic::WindowData out = w;
  const std::size_t n = w.paired.size(), keep = n - count;
  out.paired.time_s.clear();
  out.paired.reference_nT.resize(static_cast<Eigen::Index>(keep), 3);
  out.paired.test_nT.resize(static_cast<Eigen::Index>(keep), 3);
  Eigen::Index row = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (i >= first && i < first + count) continue;
    out.paired.time_s.push_back(w.paired.time_s[i]);
    out.paired.reference_nT.row(row) = w.paired.reference_nT.row(static_cast<Eigen::Index>(i));
    out.paired.test_nT.row(row) = w.paired.test_nT.row(static_cast<Eigen::Index>(i));
    ++row;
  }
  return out;
}

}  // namespace

TEST(EstimateWindow, CompleteWindowIsAcceptedAndGapsAreFlagged) {
  mic::SimulatedPair pair;
  const mic::WindowData full = simulated_window(7200.0, 5, &pair);
  mic::EstimatorSettings settings;
  mic::FdWlseEstimator estimator(settings);
  mic::WindowGapRule rule;  // 60 s, 5 %
  const mic::WindowResult ok = mic::estimate_window(full, estimator, rule);
  EXPECT_EQ(ok.estimate.quality, mic::Quality::kOk) << ok.estimate.quality_text;
  EXPECT_EQ(ok.missing(), 0u);
  const Eigen::Matrix3d z = (ok.estimate.n - pair.n_true).cwiseAbs().array() / ok.estimate.n_stderr().array();
  EXPECT_LT(z.maxCoeff(), 4.0) << "|n - n_true| / se:\n" << z << "\nse:\n" << ok.estimate.n_stderr();
  const Eigen::Vector3d mean_r = full.paired.reference_nT.colwise().mean().transpose();
  EXPECT_LT((ok.reference_mean_nT - mean_r).norm(), 1e-9) << ok.reference_mean_nT.transpose();
  // The simulated pair has no relative filter or delay: its response over the band is flat (for
  // the diagnostics' summary) within the half-width and the group delay is near 0 s.
  ASSERT_GT(ok.response.bands, 0u);
  EXPECT_LE(ok.response.max_gain_departure, 2.0 * ok.response.max_gain_departure_ci95);
  EXPECT_LT(std::abs(ok.response.group_delay_s), 1.0);

  // 30 s inside: filled, not flagged.
  const mic::WindowResult small = mic::estimate_window(without_rows(full, 1000, 30), estimator, rule);
  EXPECT_EQ(small.estimate.quality, mic::Quality::kOk) << small.estimate.quality_text;
  EXPECT_EQ(small.interpolated, 30u);
  // 120 s inside: longer than max_fill.
  const mic::WindowResult long_gap = mic::estimate_window(without_rows(full, 1000, 120), estimator, rule);
  EXPECT_EQ(long_gap.estimate.quality, mic::Quality::kGaps);
  EXPECT_TRUE(long_gap.long_gap);
  // Missing at the end (a silent topic): counted although regularize_and_fill trims it.
  const mic::WindowResult tail = mic::estimate_window(without_rows(full, 7000, 200), estimator, rule);
  EXPECT_EQ(tail.trailing_missing, 200u);
  EXPECT_EQ(tail.estimate.quality, mic::Quality::kGaps);
  const mic::WindowResult head = mic::estimate_window(without_rows(full, 0, 90), estimator, rule);
  EXPECT_EQ(head.leading_missing, 90u);
  EXPECT_EQ(head.estimate.quality, mic::Quality::kGaps);
  // Many short gaps: more than 5 % interpolated.
  mic::WindowData holes = full;
  for (std::size_t g = 0; g < 20; ++g) holes = without_rows(holes, 100 + g * 300, 20);
  const mic::WindowResult many = mic::estimate_window(holes, estimator, rule);
  EXPECT_EQ(many.interpolated, 400u);
  EXPECT_EQ(many.estimate.quality, mic::Quality::kGaps) << many.estimate.quality_text;
}

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

TEST(StreamMonitor, ForwardJumpsStrayStampsAndConfirmedBackwardJumps) {
  using Jump = mic::StreamMonitor::Jump;
  mic::StreamMonitor m;
  const double threshold = 60.0;
  double t = 1.0e9;
  for (int k = 0; k < 10; ++k) EXPECT_EQ(m.observe(t += 1.0, 0.0, "f", threshold), Jump::kNone);
  EXPECT_EQ(m.observe(t += 3600.0, 0.0, "f", threshold), Jump::kForward);  // clock jumps ahead
  EXPECT_EQ(m.observe(t += 1.0, 0.0, "f", threshold), Jump::kNone);
  EXPECT_EQ(m.observe(0.0, 0.0, "f", threshold), Jump::kNone);  // one stray stamp
  EXPECT_EQ(m.observe(t += 1.0, 0.0, "f", threshold), Jump::kNone);
  EXPECT_EQ(m.stray, 1u);
  EXPECT_EQ(m.jumps_backward, 0u);
  EXPECT_EQ(m.observe(t - 7200.0, 0.0, "f", threshold), Jump::kNone);  // clock set back: first sample
  EXPECT_EQ(m.observe(t - 7199.0, 0.0, "f", threshold), Jump::kBackward);  // confirmed
  EXPECT_EQ(m.observe(t - 7198.0, 0.0, "f", threshold), Jump::kNone);
  EXPECT_EQ(m.jumps_forward, 1u);
  EXPECT_EQ(m.jumps_backward, 1u);
  EXPECT_EQ(m.stray, 1u);
  EXPECT_EQ(m.messages, 17u);
  EXPECT_DOUBLE_EQ(m.newest_stamp_s, t - 7198.0);
  // Small disorder is neither.
  EXPECT_EQ(m.observe(t - 7210.0, 0.0, "f", threshold), Jump::kNone);
  EXPECT_EQ(m.stray, 1u);
}
