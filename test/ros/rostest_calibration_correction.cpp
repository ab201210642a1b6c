// rostest_calibration, correction_reload.test (Calibration.CorrectionFileReload): correction_node
// fed by its calibration file only (~reload_period): missing, valid, half-written, replaced.
#include "calibration_harness.hpp"
#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"

#include <Eigen/LU>

#include <cstdio>
#include <fstream>

using namespace calibration_rostest;

TEST(Calibration, CorrectionFileReload) {
  // correction_node with ~reload_period and no calibration topic traffic: its only source is
  // the file. Missing file -> nothing published; a valid file -> adopted and applied; a
  // half-written file -> an error in the diagnostics and the previous calibration kept; a new
  // valid file -> adopted. Wall-clock time (no /use_sim_time) in this test.
  Harness h(simulation(600.0, 23));
  const std::string corrected = "/reload/corrected";
  const std::string file = param("calibration_file");
  ASSERT_FALSE(file.empty());
  std::remove(file.c_str());
  h.subscribe_corrected(corrected);
  ASSERT_TRUE(h.wait_for_connections(0, 1, 30.0, /*calibration_publisher=*/false));
  auto diagnostic = [&]() { return h.latest_diagnostic("correction_reload"); };
  auto test_value = [&](std::size_t k) { return Eigen::Vector3d(h.pair().test.values_nT.row(k).transpose()); };

  // 1. No file: nothing corrected.
  h.publish(0, 100, false, true, 0.0, 1000.0);
  ASSERT_TRUE(h.wait([&] { return value_of(diagnostic(), "received") == 100; }, kPatience_s));
  {
    std::lock_guard<std::mutex> lock(h.mutex());
    EXPECT_TRUE(h.corrected(corrected).empty());
    EXPECT_EQ(value_of(diagnostic(), "dropped, no calibration"), 100u);
    EXPECT_EQ(diagnostic()->level, 1) << diagnostic()->message;
    EXPECT_NE(diagnostic()->values.at("calibration file state").find("missing"), std::string::npos);
  }

  // 2. A valid file appears (written atomically, as calibration_node does).
  mic::MagnetometerCalibration c;
  c.header.stamp = ros::Time().fromSec(h.start_s() + 100.0);
  c.header.frame_id = c.reference_frame_id = "reference_frame";
  c.test_frame_id = "test_frame";
  c.test_name = "reload";
  c.window_start = ros::Time().fromSec(h.start_s());
  c.window_end = ros::Time().fromSec(h.start_s() + 99.0);
  c.sample_period = 1.0;
  c.quality = mic::MagnetometerCalibration::QUALITY_OK;
  c.quality_text = "ok";
  c.accepted = true;
  const Eigen::Matrix3d n_true = h.pair().n_true;
  for (int k = 0; k < 9; ++k) c.matrix[k] = n_true(k / 3, k % 3);
  for (int k = 0; k < 9; ++k) c.matrix_covariance[10 * k] = 1e-12;
  c.covariance_cells = 200.0;
  c.interval_quantile = mic::student_t_two_sided_quantile(0.05, 200.0);
  mic::write_file_atomically(file, mic::calibration_to_yaml(c, "test"));
  ASSERT_TRUE(h.wait([&] {
    const DiagnosticRecord* d = diagnostic();
    return d != nullptr && d->values.count("calibration source") && d->values.at("calibration source") == "file " + file;
  }, kPatience_s)) << "the file was not adopted";
  h.publish(100, 200, false, true, 0.0, 1000.0);
  ASSERT_TRUE(h.wait([&] { return h.corrected(corrected).size() == 100; }, kPatience_s));

  // 3. A half-written file (not atomic): refused, the calibration in use is kept.
  const std::string text = mic::calibration_to_yaml(c, "test");
  {
    std::ofstream out(file, std::ios::trunc);
    out << text.substr(0, text.size() / 2);
  }
  ASSERT_TRUE(h.wait([&] {
    const DiagnosticRecord* d = diagnostic();
    return d != nullptr && d->message.find("calibration file unusable") != std::string::npos;
  }, kPatience_s)) << "no diagnostic for the half-written file";
  {
    std::lock_guard<std::mutex> lock(h.mutex());
    EXPECT_EQ(diagnostic()->level, 1) << diagnostic()->message;  // a warning: still correcting
    EXPECT_EQ(diagnostic()->values.at("calibration source"), "file " + file);
  }
  h.publish(200, 300, false, true, 0.0, 1000.0);
  ASSERT_TRUE(h.wait([&] { return h.corrected(corrected).size() == 200; }, kPatience_s));

  // 4. A new valid file: adopted.
  mic::MagnetometerCalibration next = c;
  next.window_start = ros::Time().fromSec(h.start_s() + 300.0);
  next.window_end = ros::Time().fromSec(h.start_s() + 399.0);
  for (int k = 0; k < 9; ++k) next.matrix[k] = 1.001 * n_true(k / 3, k % 3);
  mic::write_file_atomically(file, mic::calibration_to_yaml(next, "test"));
  ASSERT_TRUE(h.wait([&] {
    const DiagnosticRecord* d = diagnostic();
    return d != nullptr && d->values.count("calibration window") &&
           d->values.at("calibration window").find("00:05:00") != std::string::npos && d->level == 0;
  }, kPatience_s)) << "the new file was not adopted";
  h.publish(300, 400, false, true, 0.0, 1000.0);
  ASSERT_TRUE(h.wait([&] { return h.corrected(corrected).size() == 300; }, kPatience_s));

  std::lock_guard<std::mutex> lock(h.mutex());
  const auto& out = h.corrected(corrected);
  const Eigen::Matrix3d first = n_true.inverse().transpose(), second = (1.001 * n_true).inverse().transpose();
  for (std::size_t i = 0; i < out.size(); ++i) {
    const std::size_t k = 100 + i;
    EXPECT_DOUBLE_EQ(out[i].stamp_s, h.pair().reference.time_s[k]);
    const Eigen::Matrix3d& applied = k < 300 ? first : second;
    EXPECT_LT((out[i].field_nT - applied * test_value(k)).norm(), 1e-6) << "sample " << k;
  }
  EXPECT_EQ(value_of(diagnostic(), "calibrations adopted"), 2u);
  std::remove(file.c_str());
}
