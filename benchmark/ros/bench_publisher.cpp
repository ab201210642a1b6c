// bench_publisher: one reference and N test instruments as sensor_msgs/MagneticField streams
// from the core simulator (simulate_pair), paced at `speed` times real time, for the network
// benchmark and the soak of calibration_node/correction_node (scripts/bench_network.sh,
// scripts/bench_soak.sh build and run it; it is not part of the CMake build: benchmark/*.cpp
// are Google-benchmark programs without ROS).
//
//   bench_publisher --pairs N --period 0.1 --speed 1 --duration 120 [--record 3600]
//                   [--start 1747180800] [--seed 1] [--reference-topic /bench/reference]
//                   [--test-prefix /bench/test_] [--frame-reference ref] [--frame-test test]
//
// One record of `record` s (sample period `period`) is simulated once and looped (stamps keep
// running; the values jump at each loop, which the calibration windows see as ordinary data);
// every test instrument publishes the same test record (same n_true) on <test-prefix><i>.
// Each tick publishes the reference sample, then every test sample, with the same stamp. The
// publisher waits for a subscriber on every topic before the first sample, and at the end
// prints "published <ticks> samples per topic, <late> ticks late (publisher behind)" so that
// the caller can compare with the node's counters.
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <ros/ros.h>
#include <sensor_msgs/MagneticField.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

int main(int argc, char** argv) {
  ros::init(argc, argv, "bench_publisher", ros::init_options::AnonymousName);
  int pairs = 50;
  double period = 0.1, speed = 1.0, duration = 120.0, record = 3600.0, start = 1747180800.0;
  unsigned long seed = 1;
  std::string reference_topic = "/bench/reference", test_prefix = "/bench/test_";
  std::string frame_reference = "bench_reference", frame_test = "bench_test";
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string o = argv[i];
    const char* v = argv[i + 1];
    if (o == "--pairs") pairs = std::atoi(v);
    else if (o == "--period") period = std::atof(v);
    else if (o == "--speed") speed = std::atof(v);
    else if (o == "--duration") duration = std::atof(v);
    else if (o == "--record") record = std::atof(v);
    else if (o == "--start") start = std::atof(v);
    else if (o == "--seed") seed = std::strtoul(v, nullptr, 10);
    else if (o == "--reference-topic") reference_topic = v;
    else if (o == "--test-prefix") test_prefix = v;
    else if (o == "--frame-reference") frame_reference = v;
    else if (o == "--frame-test") frame_test = v;
    else {
      std::fprintf(stderr, "bench_publisher: unknown option %s\n", o.c_str());
      return 2;
    }
  }
  if (pairs < 1 || period <= 0 || speed <= 0 || duration <= 0 || record < 100 * period) {
    std::fprintf(stderr, "bench_publisher: impossible option\n");
    return 2;
  }
  mic::SimulationSettings sim;
  sim.start_time_s = start;
  sim.duration_s = record;
  sim.sample_period_s = period;
  sim.seed = seed;
  sim.keep_clean_field = false;
  const mic::SimulatedPair pair = mic::simulate_pair(sim);
  const std::size_t m = pair.reference.size();

  ros::NodeHandle nh;
  const std::uint32_t queue = 100000;
  ros::Publisher reference = nh.advertise<sensor_msgs::MagneticField>(reference_topic, queue);
  std::vector<ros::Publisher> tests;
  for (int i = 0; i < pairs; ++i) {
    tests.push_back(nh.advertise<sensor_msgs::MagneticField>(test_prefix + std::to_string(i), queue));
  }
  // Wait (up to 60 s) for a subscriber on every topic: nothing early is lost.
  const auto wait_until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  auto all_connected = [&] {
    if (reference.getNumSubscribers() == 0) return false;
    for (const auto& p : tests)
      if (p.getNumSubscribers() == 0) return false;
    return true;
  };
  while (ros::ok() && !all_connected() && std::chrono::steady_clock::now() < wait_until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (!all_connected()) {
    std::fprintf(stderr, "bench_publisher: not every topic has a subscriber after 60 s\n");
    return 1;
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));

  const auto ticks = static_cast<std::uint64_t>(duration / period + 0.5);
  const auto t0 = std::chrono::steady_clock::now();
  std::uint64_t late = 0, k = 0;
  sensor_msgs::MagneticField msg;
  msg.magnetic_field_covariance[0] = msg.magnetic_field_covariance[4] = msg.magnetic_field_covariance[8] = 4e-22;
  for (; k < ticks && ros::ok(); ++k) {
    const auto due = t0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>(static_cast<double>(k) * period / speed));
    const auto now = std::chrono::steady_clock::now();
    if (now < due) {
      std::this_thread::sleep_until(due);
    } else if (now - due > std::chrono::milliseconds(100)) {
      ++late;
    }
    const std::size_t i = k % m;
    // Exact stamps: whole seconds plus a multiple of the period (no accumulated rounding).
    const auto whole = static_cast<std::uint32_t>(start);
    msg.header.stamp = ros::Time(whole) + ros::Duration(static_cast<double>(k) * period);
    msg.header.frame_id = frame_reference;
    msg.magnetic_field.x = pair.reference.values_nT(static_cast<Eigen::Index>(i), 0) * 1e-9;
    msg.magnetic_field.y = pair.reference.values_nT(static_cast<Eigen::Index>(i), 1) * 1e-9;
    msg.magnetic_field.z = pair.reference.values_nT(static_cast<Eigen::Index>(i), 2) * 1e-9;
    reference.publish(msg);
    msg.header.frame_id = frame_test;
    msg.magnetic_field.x = pair.test.values_nT(static_cast<Eigen::Index>(i), 0) * 1e-9;
    msg.magnetic_field.y = pair.test.values_nT(static_cast<Eigen::Index>(i), 1) * 1e-9;
    msg.magnetic_field.z = pair.test.values_nT(static_cast<Eigen::Index>(i), 2) * 1e-9;
    for (auto& p : tests) p.publish(msg);
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("published %llu samples per topic (%d test topics) in %.1f s wall, %llu ticks late (publisher behind)\n",
              static_cast<unsigned long long>(k), pairs, wall, static_cast<unsigned long long>(late));
  std::fflush(stdout);
  std::this_thread::sleep_for(std::chrono::seconds(2));  // let the queues drain
  return 0;
}
