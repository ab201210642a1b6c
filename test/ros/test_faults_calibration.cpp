// Fault injection into calibration_node (rostest; test/ros/test_faults_calibration.test launches
// the node: window 1800 s, step 1800 s, 1 Hz, default band). The test publishes a simulated pair
// (core simulator) as an unpaced burst of stamps (no /use_sim_time: windows and pairing use
// stamps) over three windows and one closing sample:
//   window 1  [T0, T0+1800)        good data                         -> accepted
//   window 2  [T0+1800, T0+3600)   every test reading NaN (a driver publishing NaN for a
//                                  failed sensor)                    -> never accepted: today
//                                  no message at all ("could not be prepared", ERROR log,
//                                  "windows failed" 1); the file keeps window 1
//   window 3  [T0+3600, T0+5400)   good data, every test message sent twice (duplicated stamps)
//                                  -> duplicates counted (1800), each stamp paired once,
//                                     accepted, n_true recovered
// Not covered elsewhere: test/ros (rostest_calibration) covers silent topics, time jumps,
// decimation, two instruments, bad parameters, correction reloads; none feeds NaN or duplicates.
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <magnetometer_insitu_calibration/MagnetometerCalibration.h>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/MagneticField.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

constexpr double kT0 = 1747180800.0;  // multiple of 1800
constexpr double kWindow = 1800.0;

bool wait_for(const std::function<bool()>& done, double timeout_s) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (ros::ok() && ros::WallTime::now() < deadline) {
    if (done()) return true;
    ros::WallDuration(0.02).sleep();
  }
  return done();
}

sensor_msgs::MagneticField message(double stamp_s, const std::string& frame, const Eigen::Vector3d& nT) {
  sensor_msgs::MagneticField m;
  m.header.stamp = ros::Time(static_cast<std::uint32_t>(stamp_s));
  m.header.frame_id = frame;
  m.magnetic_field.x = nT(0) * 1e-9;
  m.magnetic_field.y = nT(1) * 1e-9;
  m.magnetic_field.z = nT(2) * 1e-9;
  for (int i = 0; i < 3; ++i) m.magnetic_field_covariance[static_cast<std::size_t>(4 * i)] = 1e-22;
  return m;
}

TEST(CalibrationFaults, NanWindowRejectedAndDuplicatesPairedOnce) {
  ros::NodeHandle nh;
  std::mutex mutex;
  std::vector<mic::MagnetometerCalibration> calibrations;
  std::map<std::string, std::string> channel;  // newest diagnostics values of the test channel
  auto cal_sub = nh.subscribe<mic::MagnetometerCalibration>(
      "/faults/calibration", 100, [&](const mic::MagnetometerCalibration::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mutex);
        calibrations.push_back(*m);
      });
  auto diag_sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 1000, [&](const diagnostic_msgs::DiagnosticArray::ConstPtr& a) {
        std::lock_guard<std::mutex> lock(mutex);
        for (const auto& s : a->status) {
          if (s.name.find("calibration_faults") == std::string::npos) continue;
          bool is_channel = false;
          for (const auto& kv : s.values) is_channel = is_channel || kv.key == "paired";
          if (!is_channel) continue;
          for (const auto& kv : s.values) channel[kv.key] = kv.value;
        }
      });
  auto counter = [&](const std::string& key) -> long long {
    std::lock_guard<std::mutex> lock(mutex);
    const auto it = channel.find(key);
    return it == channel.end() ? -1 : std::stoll(it->second);
  };
  ros::Publisher ref_pub = nh.advertise<sensor_msgs::MagneticField>("/faults/reference", 100000);
  ros::Publisher test_pub = nh.advertise<sensor_msgs::MagneticField>("/faults/test", 100000);
  ASSERT_TRUE(wait_for([&] { return ref_pub.getNumSubscribers() > 0 && test_pub.getNumSubscribers() > 0 &&
                                    cal_sub.getNumPublishers() > 0; },
                       30.0));

  mic::SimulationSettings sim;
  sim.start_time_s = kT0;
  sim.duration_s = 3 * kWindow + 10;
  sim.sample_period_s = 1.0;
  sim.seed = 7;
  const mic::SimulatedPair pair = mic::simulate_pair(sim);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::size_t n = pair.reference.size();
  for (std::size_t i = 0; i < n; ++i) {
    const double t = kT0 + static_cast<double>(i);
    if (t > kT0 + 3 * kWindow) break;  // the closing sample T0+5400 completes window 3
    const Eigen::Vector3d r = pair.reference.values_nT.row(static_cast<Eigen::Index>(i)).transpose();
    const Eigen::Vector3d v = pair.test.values_nT.row(static_cast<Eigen::Index>(i)).transpose();
    const bool nan_window = t >= kT0 + kWindow && t < kT0 + 2 * kWindow;
    const bool duplicate_window = t >= kT0 + 2 * kWindow && t < kT0 + 3 * kWindow;
    ref_pub.publish(message(t, "faults_reference", r));
    const auto m = message(t, "faults_test", nan_window ? Eigen::Vector3d(nan, nan, nan) : v);
    test_pub.publish(m);
    if (duplicate_window) test_pub.publish(m);
    // About 1000 stamp-s per wall s: the pairer waits pairing_max_wait = 600 stamp-s for a
    // partner, i.e. 0.6 s of arrival skew between the two topics (5000x was measured to
    // exceed it now and then on a loaded machine: samples counted unpaired, not a node bug).
    if (i % 50 == 0) ros::WallDuration(0.05).sleep();
  }

  ASSERT_TRUE(wait_for([&] {
    std::lock_guard<std::mutex> lock(mutex);
    return calibrations.size() >= 2;
  }, 40.0)) << "calibrations published: " << calibrations.size();
  // Every window ended (estimated or failed) and a calibration received for each estimated one
  // (a spurious extra message would keep this false and be caught below).
  EXPECT_TRUE(wait_for([&] {
    const long long estimated = counter("windows estimated");
    if (counter("windows failed") + estimated < 3) return false;
    std::lock_guard<std::mutex> lock(mutex);
    return static_cast<long long>(calibrations.size()) == estimated;
  }, 60.0)) << "windows estimated " << counter("windows estimated") << ", failed " << counter("windows failed");
  std::vector<mic::MagnetometerCalibration> got;
  {
    std::lock_guard<std::mutex> lock(mutex);
    got = calibrations;
    std::string dump;
    for (const auto& kv : channel) dump += kv.first + "=" + kv.second + "; ";
    std::printf("test_faults_calibration: channel diagnostics: %s\n", dump.c_str());
  }
  // The NaN window publishes nothing: the node cannot prepare it ("no epoch has all six
  // components finite"), logs an ERROR and counts it as failed. Never accepted, never a file.
  ASSERT_EQ(got.size(), 2u);
  EXPECT_NEAR(got[0].window_start.toSec(), kT0, 1.0);
  EXPECT_TRUE(got[0].accepted) << got[0].quality_text;
  EXPECT_NEAR(got[1].window_start.toSec(), kT0 + 2 * kWindow, 1.0) << "the NaN window was published";
  for (const auto& c : got) {
    EXPECT_FALSE(c.accepted && std::abs(c.window_start.toSec() - (kT0 + kWindow)) < 1.0)
        << "a window whose test readings are all NaN was accepted";
  }
  EXPECT_EQ(counter("windows failed"), 1);
  EXPECT_TRUE(got[1].accepted) << got[1].quality_text;
  EXPECT_LE(got[1].samples, static_cast<std::uint32_t>(kWindow)) << "duplicated stamps paired twice";
  EXPECT_EQ(got[1].filled_samples, 0u);
  // Window 3 recovers n_true within its own interval (duplicates neither biased it nor made
  // the interval shrink as if there were twice the samples: 5 standard errors), and the change
  // check finds it unchanged from window 1.
  for (std::size_t k = 0; k < 9; ++k) {
    const double se = std::sqrt(got[1].matrix_covariance[10 * k]);
    EXPECT_NEAR(got[1].matrix[k], pair.n_true(static_cast<Eigen::Index>(k / 3), static_cast<Eigen::Index>(k % 3)),
                5.0 * se)
        << "element " << k;
  }
  EXPECT_EQ(counter("calibration changes detected"), 0);
  // Diagnostics: duplicates counted, each stamp paired once, nothing unpaired in good windows.
  EXPECT_TRUE(wait_for([&] { return counter("test messages") >= static_cast<long long>(4 * kWindow + 1); }, 60.0));
  EXPECT_EQ(counter("duplicates"), static_cast<long long>(kWindow));
  EXPECT_LE(counter("paired"), static_cast<long long>(3 * kWindow + 1));
  EXPECT_GE(counter("paired"), static_cast<long long>(2 * kWindow));
  EXPECT_EQ(counter("test messages"), static_cast<long long>(4 * kWindow + 1));
  EXPECT_EQ(counter("windows accepted"), 2);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_faults_calibration");
  ros::NodeHandle nh;
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  spinner.stop();
  return result;
}
