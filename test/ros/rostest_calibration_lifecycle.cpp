// rostest_calibration, the accepted calibration over a node's life:
//   Calibration.ChangeDetected      test_calibration_change.test  scale ratio steps mid-run: change
//                                                                 WARN after the step, never before
//   Calibration.ResumeAfterRestart  test_calibration_resume.test  calibration_node started, stopped
//                                                                 and restarted by the test: the
//                                                                 persisted calibration at once,
//                                                                 and (~publish_tf) its rotation
//                                                                 on /tf_static; a third,
//                                                                 on another frame, refuses it
//   Calibration.ResumeRetractsAFileRefusedAtTheFirstSample  test_calibration_resume.test
//                                  a file ending after the stream's first sample: published at
//                                  start, retracted (accepted false) when refused
//   Calibration.CorrectionRefusesACalibrationOfAnotherStream  correction_stream.test
//                                  correction_node's file of a later window, another frame or
//                                  test refused at the first sample; the day before adopted
#include "calibration_harness.hpp"
#include "child_process.hpp"
#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"

#include <tf2_msgs/TFMessage.h>

#include <Eigen/Geometry>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>

using namespace calibration_rostest;

TEST(Calibration, ChangeDetected) {
  // Windows of 1 h every 30 min (test_calibration_change.test). 5 h of pairs; from 3 h on the test
  // instrument's x scale ratio is 2 % larger (1-h windows give it +- 0.3 %; the same field and noise: a second simulation with
  // the same seed spliced in). The accepted calibration is the first window's; every window is
  // checked against it: no change before the step, a WARN with the check's text after it.
  const std::size_t samples = 18000, change_index = 10800;
  mic::SimulationSettings before = simulation(static_cast<double>(samples), 23);
  mic::SimulationSettings after = before;
  after.scale_ratio(0) += 0.02;
  Harness h(before);
  const mic::SimulatedPair changed = mic::simulate_pair(after);
  ASSERT_TRUE(changed.reference.values_nT.isApprox(h.pair().reference.values_nT)) << "not the same field";
  h.splice_test(changed, change_index);
  const double change_s = h.pair().reference.time_s[change_index];
  ASSERT_TRUE(h.wait_for_connections(1, 1)) << "nodes did not connect";
  const ros::WallTime started = ros::WallTime::now();
  h.publish(0, samples, true, true);
  // Every window that ends inside the data estimated; the diagnostics report the latest.
  const std::size_t expected_windows = 9;  // starts 0, 0.5, ..., 4 h (if t0 is on the 30-min grid)
  const bool done = h.wait_ticking([&] {
    const DiagnosticRecord* d = h.latest_diagnostic("calibration_chg: chg");
    return h.calibrations().size() >= expected_windows - 1 && d != nullptr &&
           value_of(d, "windows estimated") == h.calibrations().size();
  }, kPatience_s);
  EXPECT_TRUE(h.wait_fresh_diagnostics({"calibration_chg: chg"}, 120.0)) << "no diagnostics after the last window";
  std::lock_guard<std::mutex> lock(h.mutex());
  EXPECT_TRUE(done) << "timed out waiting for the windows";
  std::printf("[ timing ] %zu pairs, %zu windows in %.2f s wall\n", samples, h.calibrations().size(),
              (ros::WallTime::now() - started).toSec());
  for (const auto& c : h.calibrations()) {
    std::printf("[ result ] window %.0f .. %.0f s: accepted %d, scale x %.6f +- %.6f\n", c.window_start.toSec() - h.start_s(),
                c.window_end.toSec() - h.start_s(), c.accepted, c.scale_ratio[0], c.scale_ratio_ci95[0]);
  }
  std::size_t warn_before = 0, warn_after = 0, checked_before = 0;
  bool changed_reported = false;
  for (const DiagnosticRecord* r : h.all_diagnostics("calibration_chg: chg")) {
    const bool warn = r->level == 1 && r->message.find("calibration changed") != std::string::npos;
    const auto status = r->values.find("change status");
    if (r->sim_time_s < change_s) {
      warn_before += warn;
      checked_before += status != r->values.end() && status->second == "unchanged";
      EXPECT_EQ(value_of(r, "calibration changes detected"), 0u) << "change reported at " << r->sim_time_s - h.start_s();
    } else {
      warn_after += warn;
      changed_reported |= status != r->values.end() && status->second == "changed";
    }
  }
  EXPECT_EQ(warn_before, 0u) << "change WARN before the step";
  EXPECT_GT(checked_before, 0u) << "no window was checked (unchanged) before the step";
  EXPECT_GT(warn_after, 0u) << "no change WARN after the step";
  EXPECT_TRUE(changed_reported);
  const DiagnosticRecord* last = h.latest_diagnostic("calibration_chg: chg");
  ASSERT_NE(last, nullptr);
  EXPECT_EQ(last->level, 1) << last->message;
  EXPECT_NE(last->message.find("calibration changed"), std::string::npos) << last->message;
  EXPECT_EQ(last->values.at("change status"), "changed");
  EXPECT_EQ(last->values.at("accepted calibration source"), "first window accepted since start");
  // The relative response summary (simulated pair: no filter, no delay between the instruments).
  ASSERT_EQ(last->values.count("response group delay (s)"), 1u);
  EXPECT_LT(std::abs(std::stod(last->values.at("response group delay (s)"))), 1.0);
  EXPECT_GT(std::stod(last->values.at("response bands in the band used")), 0.0);
  EXPECT_GE(value_of(last, "calibration changes detected"), 1u);
  // The windows wholly after the step measure the new scale ratio.
  const auto& last_window = h.calibrations().back();
  EXPECT_GE(last_window.window_start.toSec(), change_s);
  EXPECT_NEAR(last_window.scale_ratio[0], after.scale_ratio(0),
              truth_bound(last_window, 1) * last_window.scale_ratio_ci95[0] + 1e-12);
}

// ---------------------------------------------------------------------------------------------

namespace {

using mic::test::spawn_process;
using Child = mic::test::ChildProcess;

/// An accepted calibration file's content: test `test_name` on `frame_id`, n = `n`, a window of
/// 30 min of 1-s samples ending at `window_end_s`, estimated a minute after it.
mic::MagnetometerCalibration accepted_calibration(const std::string& test_name, const std::string& frame_id,
                                                  double window_end_s, const Eigen::Matrix3d& n) {
  mic::MagnetometerCalibration c;
  c.header.stamp = ros::Time().fromSec(window_end_s + 60.0);
  c.header.frame_id = c.reference_frame_id = "reference_frame";
  c.test_frame_id = frame_id;
  c.test_name = test_name;
  c.window_end = ros::Time().fromSec(window_end_s);
  c.window_start = ros::Time().fromSec(window_end_s - 1799.0);
  c.sample_period = 1.0;
  c.samples = 1800;
  c.quality = mic::MagnetometerCalibration::QUALITY_OK;
  c.quality_text = "ok";
  c.accepted = true;
  for (int m = 0; m < 9; ++m) c.matrix[m] = n(m / 3, m % 3);
  for (int m = 0; m < 9; ++m) c.matrix_covariance[10 * m] = 1e-12;
  c.covariance_cells = 200.0;
  c.interval_quantile = mic::student_t_two_sided_quantile(0.05, 200.0);
  return c;
}

}  // namespace

TEST(Calibration, ResumeAfterRestart) {
  // The test starts calibration_node itself (windows of 30 min every 15 min), feeds it 1 h of
  // pairs until windows are accepted and written, stops it (SIGINT), and starts it again with the
  // same parameters and no data: the restarted node publishes the persisted calibration (latched)
  // at once, equal to the file and to the last one the first instance published, and reports it
  // loaded from file. With ~publish_tf, the restarted node also puts the persisted rotation on
  // /tf_static at once (calibration_tf.test checks the rotation itself against a known one).
  const std::string file = param("calibration_file");
  ASSERT_FALSE(file.empty());
  std::remove(file.c_str());
  const std::vector<std::string> arguments = {
      "__name:=resume_calibration_node", "_reference_topic:=" + param("reference_topic"), "_test_topic:=" + param("test_topic"),
      "_calibration_topic:=" + param("calibration_topic"), "_calibration_file:=" + file, "_test_name:=resume",
      "_window:=1800", "_step:=900", "_silent_timeout:=300", "_diagnostic_period:=5", "_publish_tf:=true"};
  Harness h(simulation(3700.0, 31));
  std::vector<tf2_msgs::TFMessage> tf_messages;  // under h.mutex()
  ros::NodeHandle nh;
  const ros::Subscriber tf_sub = nh.subscribe<tf2_msgs::TFMessage>(
      "/tf_static", 100, [&](const tf2_msgs::TFMessage::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(h.mutex());
        tf_messages.push_back(*m);
      });
  Child first{spawn_process(CALIBRATION_NODE_PATH, arguments)};
  ASSERT_GT(first.pid, 0);
  ASSERT_TRUE(h.wait_for_connections(1, 1)) << "first calibration_node did not connect";
  h.publish(0, h.pair().reference.size(), true, true);
  // Every window of the hour (30 min every 15 min: ending at 30, 45 and 60 min), so that none is
  // still being written when the first instance is stopped.
  const bool accepted = h.wait_ticking([&] {
    const DiagnosticRecord* d = h.latest_diagnostic("resume_calibration_node: resume");
    return h.calibrations().size() >= 3 && d != nullptr && value_of(d, "windows estimated") == h.calibrations().size();
  }, kPatience_s);
  mic::MagnetometerCalibration last_published;
  {
    std::lock_guard<std::mutex> lock(h.mutex());
    ASSERT_TRUE(accepted) << "the first instance accepted no calibration";
    last_published = h.calibrations().back();
  }
  ASSERT_TRUE(last_published.accepted) << last_published.quality_text;
  const bool first_stopped = first.stop();
  EXPECT_TRUE(first_stopped) << "first instance did not exit on SIGINT";
  mic::MagnetometerCalibration persisted;
  ASSERT_NO_THROW(persisted = mic::load_calibration_file(file));
  std::string difference;
  EXPECT_TRUE(mic::calibrations_equal(persisted, last_published, &difference)) << "file differs in " << difference;
  // The file keeps the cells of the window's covariance (a 30-min window: at most its 18 band
  // harmonics) and its intervals' Student quantile, which the restarted node resumes with.
  EXPECT_GT(persisted.covariance_cells, 1.0);
  EXPECT_LE(persisted.covariance_cells, 18.0);
  EXPECT_DOUBLE_EQ(persisted.interval_quantile, mic::student_t_two_sided_quantile(0.05, persisted.covariance_cells));

  // Restart: no data, no clock advance until the calibration is in.
  std::size_t before_restart = 0, tf_before_restart = 0;
  {
    std::lock_guard<std::mutex> lock(h.mutex());
    before_restart = h.calibrations().size();
    tf_before_restart = tf_messages.size();
  }
  const ros::WallTime restarted = ros::WallTime::now();
  Child second{spawn_process(CALIBRATION_NODE_PATH, arguments)};
  ASSERT_GT(second.pid, 0);
  const bool resumed = h.wait([&] { return h.calibrations().size() > before_restart; }, kPatience_s);
  const double resume_wall_s = (ros::WallTime::now() - restarted).toSec();
  const bool tf_resumed = h.wait([&] { return tf_messages.size() > tf_before_restart; }, kPatience_s);
  // Diagnostics of the restarted node (they run on /clock).
  const bool diagnosed = h.wait_ticking([&] {
    const DiagnosticRecord* d = h.latest_diagnostic("resume_calibration_node: resume");
    return d != nullptr && d->values.count("loaded from file") && d->values.at("loaded from file") == "True";
  }, kPatience_s);
  // A sample of the same stream after the persisted window: the file is kept.
  const std::string persisted_frame = persisted.test_frame_id;
  h.publish_test_sample(0, persisted.window_end.toSec() + 60.0, persisted_frame);
  const double kept_after_s = persisted.window_end.toSec() + 60.0;
  const bool kept = h.wait_ticking([&] {
    const DiagnosticRecord* d = h.latest_diagnostic("resume_calibration_node: resume");
    return d != nullptr && d->sim_time_s > kept_after_s + 2.0;
  }, kPatience_s);
  const bool second_stopped = second.stop();
  std::lock_guard<std::mutex> lock(h.mutex());
  std::printf("[ timing ] restarted node published the persisted calibration %.2f s (wall) after its start\n",
              resume_wall_s);
  ASSERT_TRUE(resumed) << "the restarted node published nothing";
  EXPECT_LT(resume_wall_s, 10.0);
  EXPECT_EQ(h.calibrations().size(), before_restart + 1) << "more than the persisted calibration";
  const mic::MagnetometerCalibration& again = h.calibrations().back();
  EXPECT_TRUE(mic::calibrations_equal(again, persisted, &difference)) << "differs from the file in " << difference;
  EXPECT_TRUE(diagnosed) << "no 'loaded from file' diagnostic";
  const DiagnosticRecord* d = h.latest_diagnostic("resume_calibration_node: resume");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->values.at("resume at start"), "resumed from file");
  EXPECT_EQ(d->values.at("accepted calibration source"), "file (loaded at start)");
  EXPECT_EQ(value_of(d, "windows estimated"), 0u);
  EXPECT_TRUE(kept) << "no diagnostics after a sample of the stream";
  EXPECT_EQ(d->values.at("accepted calibration source"), "file (loaded at start)") << "dropped on its own stream";
  EXPECT_TRUE(second_stopped);
  // The persisted calibration's rotation on /tf_static from the restarted node: the rotation
  // vector of its inverse is the file's misalignment_deg (calibration_node_tf.cpp).
  ASSERT_TRUE(tf_resumed) << "the restarted node put nothing on /tf_static";
  ASSERT_EQ(tf_messages.back().transforms.size(), 1u);
  const geometry_msgs::TransformStamped& t = tf_messages.back().transforms[0];
  EXPECT_EQ(t.header.frame_id, persisted.reference_frame_id);
  EXPECT_EQ(t.child_frame_id, persisted.test_frame_id);
  EXPECT_EQ(t.header.stamp, persisted.header.stamp);
  const Eigen::Quaterniond q(t.transform.rotation.w, t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z);
  const Eigen::AngleAxisd inverse(q.toRotationMatrix().transpose());
  const Eigen::Vector3d v = inverse.axis() * inverse.angle() * 180.0 / M_PI;
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(v(k), persisted.misalignment_deg[k], 1e-6) << "component " << k;
}

TEST(Calibration, ResumeRefusesAFileOfAnotherStream) {
  // After ResumeAfterRestart (same file): calibration_node started again on a stream whose first
  // test sample has another frame_id. The persisted calibration is published at start (the
  // correction node makes its own check), but at that sample it stops being the change check's
  // baseline and the diagnostics warn, naming the field.
  const std::string file = param("calibration_file");
  mic::MagnetometerCalibration persisted;
  ASSERT_NO_THROW(persisted = mic::load_calibration_file(file)) << "ResumeAfterRestart runs first and leaves " << file;
  const std::vector<std::string> arguments = {
      "__name:=resume_calibration_node", "_reference_topic:=" + param("reference_topic"), "_test_topic:=" + param("test_topic"),
      "_calibration_topic:=" + param("calibration_topic"), "_calibration_file:=" + file, "_test_name:=resume",
      "_window:=1800", "_step:=900", "_silent_timeout:=300", "_diagnostic_period:=5"};
  Harness h(simulation(600.0, 31));
  Child node{spawn_process(CALIBRATION_NODE_PATH, arguments)};
  ASSERT_GT(node.pid, 0);
  ASSERT_TRUE(h.wait_for_connections(1, 1)) << "calibration_node did not connect";
  const bool resumed = h.wait([&] { return !h.calibrations().empty(); }, kPatience_s);
  h.publish_test_sample(0, persisted.window_end.toSec() + 60.0, "another_frame");
  const bool refused = h.wait_ticking([&] {
    const DiagnosticRecord* d = h.latest_diagnostic("resume_calibration_node: resume");
    return d != nullptr && d->values.count("resume at start") &&
           d->values.at("resume at start").rfind("resumed file refused", 0) == 0;
  }, kPatience_s);
  const bool stopped = node.stop();
  std::lock_guard<std::mutex> lock(h.mutex());
  EXPECT_TRUE(resumed) << "the file was not published at start";
  ASSERT_TRUE(refused) << "the file of another frame was not refused";
  const DiagnosticRecord* d = h.latest_diagnostic("resume_calibration_node: resume");
  EXPECT_NE(d->values.at("resume at start").find("test_frame_id '" + persisted.test_frame_id + "'"), std::string::npos)
      << d->values.at("resume at start");
  EXPECT_EQ(d->values.at("accepted calibration source"), "none");
  EXPECT_EQ(d->values.at("loaded from file"), "False");
  EXPECT_EQ(d->level, 1) << d->message;
  EXPECT_NE(d->message.find("another_frame"), std::string::npos) << d->message;
  EXPECT_TRUE(stopped);
  std::remove(file.c_str());
}

TEST(Calibration, ResumeRetractsAFileRefusedAtTheFirstSample) {
  // A second replay of a bag: calibration_node starts with the first replay's file (this test
  // and frame, its window ending 1000 s after the stream's first sample). The node publishes the
  // file at start (a restarted station resumes at once); at the first test sample it refuses it
  // and replaces the latched message: a subscriber connecting after the refusal must not get
  // the file as accepted, but the same calibration with accepted false and the reason.
  const std::string file = param("calibration_file") + ".replay.yaml";
  Harness h(simulation(600.0, 37));
  const double first_s = h.start_s();
  const mic::MagnetometerCalibration earlier = accepted_calibration("resume", "test_frame", first_s + 1000.0, h.pair().n_true);
  mic::write_file_atomically(file, mic::calibration_to_yaml(earlier, "test"));
  const std::vector<std::string> arguments = {
      "__name:=resume_calibration_node", "_reference_topic:=" + param("reference_topic"), "_test_topic:=" + param("test_topic"),
      "_calibration_topic:=" + param("calibration_topic"), "_calibration_file:=" + file, "_test_name:=resume",
      "_window:=1800", "_step:=900", "_silent_timeout:=300", "_diagnostic_period:=5"};
  Child node{spawn_process(CALIBRATION_NODE_PATH, arguments)};
  ASSERT_GT(node.pid, 0);
  ASSERT_TRUE(h.wait_for_connections(1, 1, 60.0)) << "calibration_node did not connect";
  const bool resumed = h.wait([&] { return !h.calibrations().empty(); }, 60.0);
  h.publish_test_sample(0, first_s, "test_frame");
  const bool refused = h.wait_ticking([&] {
    const DiagnosticRecord* d = h.latest_diagnostic("resume_calibration_node: resume");
    return d != nullptr && d->values.count("resume at start") &&
           d->values.at("resume at start").rfind("resumed file refused", 0) == 0;
  }, 60.0);
  // After the refusal, a new subscriber: the latched message it gets is the latest published.
  std::vector<mic::MagnetometerCalibration> late;  // under h.mutex()
  ros::NodeHandle nh;
  ros::Subscriber late_sub;
  if (refused) {
    late_sub = nh.subscribe<mic::MagnetometerCalibration>(
        param("calibration_topic"), 10, [&](const mic::MagnetometerCalibration::ConstPtr& m) {
          std::lock_guard<std::mutex> lock(h.mutex());
          late.push_back(*m);
        });
  }
  const bool latched = refused && h.wait([&] { return !late.empty(); }, 60.0);
  late_sub.shutdown();
  const bool stopped = node.stop();
  std::remove(file.c_str());
  std::lock_guard<std::mutex> lock(h.mutex());
  ASSERT_TRUE(resumed) << "the file was not published at start";
  EXPECT_TRUE(h.calibrations().front().accepted) << "the file published at start";
  ASSERT_TRUE(refused) << "the file of an earlier replay was not refused";
  ASSERT_TRUE(latched) << "a subscriber connecting after the refusal got no message";
  const mic::MagnetometerCalibration& last = late.front();
  EXPECT_FALSE(last.accepted) << "the refused file is still the latched calibration, accepted";
  EXPECT_EQ(last.window_end, earlier.window_end) << "not the file's calibration";
  EXPECT_NE(last.quality_text.find("window_end"), std::string::npos) << last.quality_text;
  EXPECT_FALSE(h.calibrations().back().accepted) << "the last message of the topic is the accepted file";
  EXPECT_TRUE(stopped);
}

TEST(Calibration, CorrectionRefusesACalibrationOfAnotherStream) {
  // correction_node started by the test once per case, with a calibration file it loads at
  // start; the first test sample decides whether the file belongs to the stream
  // (calibration_stream_mismatch): a window ending after the first sample (a second replay of a
  // bag), another frame_id and another test name are refused (nothing corrected; the file and
  // the field named in the diagnostics' error); the same instrument's calibration of the day
  // before (a restart) is adopted and corrects every sample. Wall-clock time.
  const std::string file = param("calibration_file"), corrected = "/stream/corrected";
  ASSERT_FALSE(file.empty());
  Harness h(simulation(600.0, 23));
  h.subscribe_corrected(corrected);
  const Eigen::Matrix3d n_true = h.pair().n_true;
  struct Case {
    const char* test_name;
    const char* frame_id;
    double end_after_first_s;  ///< window_end minus the stream's first sample, s
    const char* field;         ///< the field named in the refusal; "" = adopted
  };
  const Case cases[] = {{"stream", "test_frame", 1000.0, "window_end"},
                        {"stream", "another_frame", -3600.0, "test_frame_id 'another_frame'"},
                        {"other", "test_frame", -3600.0, "test_name 'other'"},
                        {"stream", "test_frame", -86400.0, ""}};
  const std::size_t samples = 50;
  for (std::size_t i = 0; i < 4; ++i) {
    const Case& k = cases[i];
    SCOPED_TRACE(std::string("case ") + std::to_string(i) + ": " + (*k.field ? k.field : "adopted"));
    const std::size_t first = i * samples;
    const double first_s = h.start_s() + static_cast<double>(first);
    mic::write_file_atomically(
        file, mic::calibration_to_yaml(accepted_calibration(k.test_name, k.frame_id, first_s + k.end_after_first_s, n_true), "test"));
    const std::string name = "correction_stream_" + std::to_string(i);
    Child node{spawn_process(CORRECTION_NODE_PATH, {"__name:=" + name, "_test_topic:=" + param("test_topic"),
                                            "_calibration_topic:=" + param("calibration_topic"),
                                            "_corrected_topic:=" + corrected, "_calibration_file:=" + file,
                                            "_test_name:=stream", "_diagnostic_period:=0.1"})};
    ASSERT_GT(node.pid, 0);
    ASSERT_TRUE(h.wait([&] { return h.latest_diagnostic(name) != nullptr; }, kPatience_s)) << name << " did not start";
    ASSERT_TRUE(h.wait_for_connections(0, 1, 20.0, /*calibration_publisher=*/false)) << name << " did not connect";
    std::size_t corrected_before = 0;
    {
      std::lock_guard<std::mutex> lock(h.mutex());
      corrected_before = h.corrected(corrected).size();
    }
    h.publish(first, first + samples, false, true, 0.0, 1000.0);
    ASSERT_TRUE(h.wait([&] { return value_of(h.latest_diagnostic(name), "received") == samples; }, kPatience_s));
    if (*k.field) {
      ASSERT_TRUE(h.wait([&] { return value_of(h.latest_diagnostic(name), "dropped, no calibration") == samples; }, kPatience_s));
      std::lock_guard<std::mutex> lock(h.mutex());
      const DiagnosticRecord* d = h.latest_diagnostic(name);
      EXPECT_EQ(h.corrected(corrected).size(), corrected_before) << "a refused calibration corrected samples";
      EXPECT_EQ(d->level, 2) << d->message;  // no calibration and the file refused: an error
      EXPECT_NE(d->message.find("calibration file unusable: " + file + ": refused"), std::string::npos) << d->message;
      EXPECT_NE(d->message.find(k.field), std::string::npos) << d->message;
      EXPECT_EQ(d->values.at("calibration source"), "none");
      EXPECT_EQ(value_of(d, "calibrations rejected"), 1u);
    } else {
      ASSERT_TRUE(h.wait([&] { return h.corrected(corrected).size() == corrected_before + samples; }, kPatience_s));
      std::lock_guard<std::mutex> lock(h.mutex());
      const auto& out = h.corrected(corrected);
      const Eigen::Matrix3d applied = n_true.inverse().transpose();
      for (std::size_t j = 0; j < samples; ++j) {
        const Eigen::Vector3d t = h.pair().test.values_nT.row(first + j).transpose();
        EXPECT_LT((out[corrected_before + j].field_nT - applied * t).norm(), 1e-6) << "sample " << first + j;
      }
      EXPECT_EQ(h.latest_diagnostic(name)->values.at("calibration source"), "file " + file);
    }
  }
  std::remove(file.c_str());
}
