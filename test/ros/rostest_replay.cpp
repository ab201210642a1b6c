// Replay agreement (test/ros/replay_agreement.test): a bag of a simulated 1 Hz pair with spikes
// played by launch/replay.launch (rosbag play --clock, /use_sim_time) into calibration_node and
// correction_node gives, window for window, the calibration that calibrate_records --bag wrote
// for the same bag and the same windows (--window/--step; both despiking, or neither): the node
// and the program share the per-window stage. Agreement to numerical noise: every number of the
// message within 1e-7 relative (plus 1e-12 absolute) of the JSON; counts, harmonics and quality
// equal. With a remote observatory in the bag (param remote), both estimate every window on the
// remote's instruments (~remote_topic, --remote-topic) and agree on it too.
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include <magnetometer_insitu_calibration/MagnetometerCalibration.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <ros/ros.h>
#include <sensor_msgs/MagneticField.h>

#include <cmath>
#include <fstream>
#include <map>
#include <mutex>

namespace mic = magnetometer_insitu_calibration;

namespace {

constexpr double kRelative = 1e-7;
constexpr double kAbsolute = 1e-12;

/// |live - offline| <= kRelative * max(|live|, |offline|) + kAbsolute.
::testing::AssertionResult agrees(double live, double offline) {
  if (std::abs(live - offline) <= kRelative * std::max(std::abs(live), std::abs(offline)) + kAbsolute) {
    return ::testing::AssertionSuccess();
  }
  return ::testing::AssertionFailure() << "live " << live << " offline " << offline << " (difference "
                                       << live - offline << ")";
}

template <typename Array>
void expect_vector(const Array& live, const nlohmann::json& offline, const std::string& what) {
  ASSERT_EQ(offline.size(), 3u) << what;
  for (std::size_t i = 0; i < 3; ++i) EXPECT_TRUE(agrees(live[i], offline[i].get<double>())) << what << "[" << i << "]";
}

template <typename Array>
void expect_pairs(const Array& live, const nlohmann::json& offline, const std::string& what) {
  const char* keys[3] = {"xy", "xz", "yz"};
  for (std::size_t i = 0; i < 3; ++i) EXPECT_TRUE(agrees(live[i], offline[keys[i]].get<double>())) << what << "." << keys[i];
}

/// Offline windows by start (ms): every window but the one that ends with the record, which the
/// live node does not complete (no sample after its end).
std::map<long long, const nlohmann::json*> expected_windows(const nlohmann::json& windows) {
  double last_end = 0.0;
  for (const auto& w : windows) last_end = std::max(last_end, mic::parse_iso8601(w["window_end"].get<std::string>()));
  std::map<long long, const nlohmann::json*> expected;
  for (const auto& w : windows) {
    if (mic::parse_iso8601(w["window_end"].get<std::string>()) < last_end) {
      expected[std::llround(1000.0 * mic::parse_iso8601(w["window_start"].get<std::string>()))] = &w;
    }
  }
  return expected;
}

/// The live message of a window against the offline report's window: counts, harmonics and
/// quality equal, every number within kRelative; with a remote, the remote's verdicts too.
void expect_window(const mic::MagnetometerCalibration& m, const nlohmann::json& o, bool remote) {
  EXPECT_NEAR(m.window_end.toSec(), mic::parse_iso8601(o["window_end"].get<std::string>()), 1e-3);
  EXPECT_EQ(m.samples, o["samples"].get<std::uint32_t>());
  EXPECT_EQ(m.filled_samples, o["filled_samples"].get<std::uint32_t>());
  EXPECT_EQ(static_cast<int>(m.harmonic_first), o["harmonic_first"].get<int>());
  EXPECT_EQ(static_cast<int>(m.harmonic_last), o["harmonic_last"].get<int>());
  EXPECT_EQ(mic::quality_name(static_cast<mic::Quality>(m.quality)), o["quality"].get<std::string>());
  EXPECT_TRUE(m.accepted);
  for (int k = 0; k < 9; ++k) {
    EXPECT_TRUE(agrees(m.matrix[k], o["matrix"][k / 3][k % 3].get<double>())) << "matrix " << k;
  }
  for (int k = 0; k < 81; ++k) {
    EXPECT_TRUE(agrees(m.matrix_covariance[k], o["matrix_covariance"][k / 9][k % 9].get<double>()))
        << "matrix_covariance " << k;
  }
  expect_vector(m.trend_nT_per_day, o["trend_nT_per_day"], "trend_nT_per_day");
  expect_vector(m.scale_ratio, o["scale_ratio"], "scale_ratio");
  expect_vector(m.scale_ratio_ci95, o["scale_ratio_ci95"], "scale_ratio_ci95");
  expect_pairs(m.nonorthogonality_deg, o["nonorthogonality_deg"], "nonorthogonality_deg");
  expect_pairs(m.nonorthogonality_ci95_deg, o["nonorthogonality_ci95_deg"], "nonorthogonality_ci95_deg");
  expect_vector(m.misalignment_deg, o["misalignment_deg"], "misalignment_deg");
  expect_vector(m.misalignment_ci95_deg, o["misalignment_ci95_deg"], "misalignment_ci95_deg");
  expect_vector(m.axis_deviation_deg, o["axis_deviation_deg"], "axis_deviation_deg");
  expect_vector(m.coherence, o["coherence"], "coherence");
  expect_vector(m.residual_rms_nT, o["residual_rms_nT"], "residual_rms_nT");
  EXPECT_TRUE(agrees(m.condition_number, o["condition_number"].get<double>())) << "condition_number";
  // The remote reference: used (or refused) in both, as strong in both, the same verdict on
  // the pair alone. Hourly windows of a quiet simulated day: the remote's first-stage F is
  // 7-56, so a few windows refuse it.
  EXPECT_EQ(static_cast<bool>(m.remote_used), o["remote_used"].get<bool>());
  EXPECT_EQ(static_cast<bool>(m.pair_biased), o["pair_biased"].get<bool>());
  if (remote) {
    EXPECT_TRUE(agrees(m.remote_strength, o["remote_strength"].get<double>())) << "remote_strength";
  }
}

}  // namespace

TEST(Replay, LiveCalibrationEqualsTheOfflineCalibrationOnTheSameWindows) {
  ros::NodeHandle nh, p("~");
  std::string json_path, calibration_topic, corrected_topic;
  double timeout_s = 150.0;
  ASSERT_TRUE(p.getParam("offline_json", json_path));
  bool despike = false, remote = false;
  ASSERT_TRUE(p.getParam("despike", despike));
  p.param("remote", remote, false);
  p.param<std::string>("calibration_topic", calibration_topic, "/replay/calibration");
  p.param<std::string>("corrected_topic", corrected_topic, "/replay/corrected");
  p.param("timeout", timeout_s, timeout_s);

  std::ifstream in(json_path);
  ASSERT_TRUE(in.good()) << json_path;
  const nlohmann::json report = nlohmann::json::parse(in);
  const nlohmann::json& windows = report["windows"];
  ASSERT_GE(windows.size(), 3u);
  ASSERT_EQ(report["settings"]["despike"], despike) << "the node and the program despike alike";
  // The bag has spikes: despiking found some (and so the despiked windows differ from the others).
  const int spikes = report["preprocessing"]["spikes_reference"].get<int>() + report["preprocessing"]["spikes_test"].get<int>();
  if (despike) {
    ASSERT_GT(spikes, 0);
  }

  const std::map<long long, const nlohmann::json*> expected = expected_windows(windows);
  ASSERT_GE(expected.size(), 2u);

  std::mutex mutex;
  std::map<long long, mic::MagnetometerCalibration> live;
  std::size_t corrected = 0;
  std::string corrected_frame;
  ros::Subscriber calibration_sub = nh.subscribe<mic::MagnetometerCalibration>(
      calibration_topic, 1000, [&](const mic::MagnetometerCalibration::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mutex);
        live[std::llround(1000.0 * m->window_start.toSec())] = *m;
      });
  ros::Subscriber corrected_sub =
      nh.subscribe<sensor_msgs::MagneticField>(corrected_topic, 10000, [&](const sensor_msgs::MagneticField::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mutex);
        ++corrected;
        corrected_frame = m->header.frame_id;
      });

  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  for (;;) {
    ros::spinOnce();
    {
      std::lock_guard<std::mutex> lock(mutex);
      std::size_t have = 0;
      for (const auto& e : expected) have += live.count(e.first);
      if (have == expected.size()) break;
    }
    if (ros::WallTime::now() > deadline) break;
    ros::WallDuration(0.05).sleep();
  }
  // The replay also drives correction_node: its first corrected sample, within the same deadline
  // (a condition, not a 0.5 s sleep: correction_node may lag on a busy machine).
  for (;;) {
    ros::spinOnce();
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (corrected > 0) break;
    }
    if (ros::WallTime::now() > deadline) break;
    ros::WallDuration(0.05).sleep();
  }

  std::lock_guard<std::mutex> lock(mutex);
  std::size_t remote_windows = 0;
  for (const auto& [start_ms, w] : expected) {
    const std::string label = (*w)["label"].get<std::string>() + " (" + (*w)["window_start"].get<std::string>() + ")";
    const auto it = live.find(start_ms);
    ASSERT_NE(it, live.end()) << "no live calibration for offline " << label << " within " << timeout_s
                              << " s; live windows received: " << live.size();
    SCOPED_TRACE(label);
    expect_window(it->second, *w, remote);
    remote_windows += it->second.remote_used;
  }
  if (remote) {
    EXPECT_GE(2 * remote_windows, expected.size()) << "most windows rest on the remote";
  } else {
    EXPECT_EQ(remote_windows, 0u);
  }
  // The replay also drives correction_node: the test stream comes out in the reference frame.
  EXPECT_GT(corrected, 0u);
  EXPECT_EQ(corrected_frame, "reference");
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "rostest_replay");
  ros::NodeHandle nh;  // keeps the node up for the whole test
  return RUN_ALL_TESTS();
}
