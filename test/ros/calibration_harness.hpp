// Shared by the rostest_calibration sources: the Harness that publishes a simulated reference /
// test pair (core simulator, known n_true) with a fast /clock and records what calibration_node
// and correction_node publish (calibrations, corrected samples, diagnostics), and small helpers.
// Private parameters of the test node: topic names and calibration file of the .test launch.
// Units: nT in the harness, tesla on the topics; the reference stream is in "reference_frame",
// the test stream in "test_frame".
#pragma once

#include "magnetometer_insitu_calibration/common/scalar_record.hpp"
#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"
#include "magnetometer_insitu_calibration/simulation/hut_temperature.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "magnetometer_insitu_calibration/simulation/station_disturbances.hpp"
#include "wait_condition.hpp"

#include <magnetometer_insitu_calibration/MagnetometerCalibration.h>
#include <magnetometer_insitu_calibration/ScalarField.h>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/Temperature.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace calibration_rostest {

inline constexpr double kTeslaPerNanotesla = 1e-9;
/// Wall seconds any wait of these tests allows for its condition: a bound that turns a broken
/// node into a failure, never reached by a working one on a slow or loaded machine.
inline constexpr double kPatience_s = 90.0;

struct DiagnosticRecord {
  double sim_time_s = 0.0;   ///< /clock when it arrived
  double node_time_s = 0.0;  ///< the publishing node's ros::Time when it published (header stamp)
  int level = 0;
  std::string message;
  std::map<std::string, std::string> values;
};

struct CorrectedSample {
  double stamp_s = 0.0;
  Eigen::Vector3d field_nT;
  Eigen::Matrix3d covariance_nT2;
  std::string frame_id;
};

inline std::string param(const std::string& name, const std::string& fallback = "") {
  std::string value;
  return ros::param::get("~" + name, value) ? value : fallback;
}

/// Publishes the simulated pair and records what the nodes publish.
class Harness {
 public:
  explicit Harness(const mic::SimulationSettings& settings)
      : settings_(settings), pair_(mic::simulate_pair(settings)), spinner_(2) {
    reference_topic_ = param("reference_topic", "/sim/reference/magnetic_field");
    test_topic_ = param("test_topic", "/sim/test/magnetic_field");
    calibration_topic_ = param("calibration_topic", "/sim/calibration");
    clock_pub_ = nh_.advertise<rosgraph_msgs::Clock>("/clock", 100000);
    reference_pub_ = nh_.advertise<sensor_msgs::MagneticField>(reference_topic_, 100000);
    test_pub_ = nh_.advertise<sensor_msgs::MagneticField>(test_topic_, 100000);
    calibration_sub_ = nh_.subscribe(calibration_topic_, 1000, &Harness::on_calibration, this);
    diagnostics_sub_ = nh_.subscribe("/diagnostics", 10000, &Harness::on_diagnostics, this);
    // Test noise actually simulated (nT rms per component, test frame): T - B n_true.
    // (about its mean: the test's baseline offset is not noise).
    mic::Readings noise = pair_.test.values_nT - pair_.field_nT * pair_.n_true;
    noise.rowwise() -= noise.colwise().mean();
    test_noise_rms_nT_ = (noise.array().square().colwise().mean()).sqrt().transpose();
    spinner_.start();
  }

  ~Harness() {
    if (testing::Test::HasFailure()) {
      std::lock_guard<std::mutex> lock(mutex_);
      dump_diagnostics();
    }
    spinner_.stop();
  }

  /// Also publishes the test stream on `topic` with `frame_id` (a second test instrument).
  /// With `stride`, only its samples first, first + stride, ... (a 1 s stream at another phase of
  /// the second than the reference's, from a 10 Hz simulation).
  void add_test_copy(const std::string& topic, const std::string& frame_id, std::size_t stride = 1,
                     std::size_t first = 0) {
    test_copies_.push_back({nh_.advertise<sensor_msgs::MagneticField>(topic, 100000), frame_id, {}, stride, first});
  }

  /// Also publishes another test instrument on `topic` with `frame_id`: its readings `values_nT`
  /// (N x 3, nT, one row per sample of the pair, its own frame), at the test's stamps.
  void add_test_instrument(const std::string& topic, const std::string& frame_id, const mic::Readings& values_nT) {
    test_copies_.push_back({nh_.advertise<sensor_msgs::MagneticField>(topic, 100000), frame_id, values_nT, 1, 0});
  }

  /// The test sees a hut's temperature (hut_temperature.hpp; the pair's test readings change), and
  /// publish() also sends the thermometer's reading (deg C, the test's stamps) on `topic`, before
  /// the test's field sample of the same stamp. Call before publishing.
  void add_hut_temperature(const mic::HutTemperatureSettings& hut, const std::string& topic) {
    hut_ = hut;
    mic::add_hut_temperature(pair_, hut);
    temperature_C_ = pair_.test.auxiliary.back().values;
    temperature_pub_ = nh_.advertise<sensor_msgs::Temperature>(topic, 100000);
  }
  const mic::HutTemperatureSettings& hut() const { return hut_; }
  std::size_t temperature_subscribers() const { return temperature_pub_.getNumSubscribers(); }

  /// A station's disturbances (station_disturbances.hpp: vehicles on a road beside the hut, seen
  /// by both sensors; spikes; steps) are added to the pair. Call before publishing.
  mic::StationDisturbanceReport add_station_disturbances(const mic::StationDisturbanceSettings& disturbances) {
    return mic::add_station_disturbances(pair_, disturbances);
  }

  /// The reference reads `scale` times the field along every axis (a scale error). Call before
  /// publishing.
  void scale_reference(double scale) { pair_.reference.values_nT *= scale; }

  /// publish() also sends an absolute scalar magnetometer's F (nT, at its own times; ScalarField
  /// in tesla, variance 0 = unknown) on `topic`: before each pair sample, F's samples stamped up
  /// to one period after it, so that a window's F is in when its last pair completes it.
  void add_scalar(const std::string& topic, const mic::ScalarRecord& scalar) {
    scalar_ = scalar;
    scalar_pub_ = nh_.advertise<mic::ScalarField>(topic, 100000);
  }
  std::size_t scalar_subscribers() const { return scalar_pub_.getNumSubscribers(); }

  /// Records MagnetometerCalibration messages of another topic (see calibrations_of()).
  void subscribe_calibration(const std::string& topic) {
    std::lock_guard<std::mutex> lock(mutex_);
    extra_calibration_subs_.push_back(nh_.subscribe<mic::MagnetometerCalibration>(
        topic, 1000, [this, topic](const mic::MagnetometerCalibration::ConstPtr& m) {
          std::lock_guard<std::mutex> lock(mutex_);
          calibrations_of_[topic].push_back(*m);
        }));
  }
  const std::vector<mic::MagnetometerCalibration>& calibrations_of(const std::string& topic) {
    return calibrations_of_[topic];
  }

  /// publish() sends every `stride`-th reference sample only (10 on a 10 Hz simulation: a 1 s
  /// reference at its whole seconds beside the 10 Hz test). Call before publishing.
  void publish_reference_every(std::size_t stride) { reference_stride_ = stride; }

  /// One raw test message (sample k of the simulation) with any stamp and frame_id.
  void publish_test_sample(std::size_t k, double stamp_s, const std::string& frame_id) {
    test_pub_.publish(field_message(ros::Time().fromSec(stamp_s), frame_id, pair_.test.values_nT.row(k), test_noise_rms_nT_));
  }

  std::size_t test_subscribers(std::size_t copy) const { return test_copies_.at(copy).publisher.getNumSubscribers(); }

  void subscribe_corrected(const std::string& topic) {
    std::lock_guard<std::mutex> lock(mutex_);
    corrected_subs_.push_back(nh_.subscribe<sensor_msgs::MagneticField>(
        topic, 100000, [this, topic](const sensor_msgs::MagneticField::ConstPtr& m) { on_corrected(topic, m); }));
  }

  /// Waits (wall time) until the nodes are connected.
  bool wait_for_connections(std::size_t reference_subscribers, std::size_t test_subscribers, double timeout_s = 30.0,
                            bool calibration_publisher = true) {
    return wait([&] {
      bool corrected_ok = true;
      for (const auto& s : corrected_subs_) corrected_ok = corrected_ok && s.getNumPublishers() > 0;
      return reference_pub_.getNumSubscribers() >= reference_subscribers &&
             test_pub_.getNumSubscribers() >= test_subscribers &&
             (!calibration_publisher || calibration_sub_.getNumPublishers() > 0) && corrected_ok;
    }, timeout_s);
  }

  /// Publishes samples [first, last) of the simulation: stamps = start + k * period +
  /// stamp_offset_s; /clock = start + k * period, never back (after wait_received's ticks it
  /// stays where they left it until the samples catch up); reference and/or test. ~rate samples
  /// per wall second.
  void publish(std::size_t first, std::size_t last, bool reference, bool test, double stamp_offset_s = 0.0,
               double rate = -1.0) {
    if (rate < 0.0) {
      rate = 2500.0;  // samples per wall second; 0: as fast as possible
      ros::param::get("~rate", rate);
    }
    const ros::WallTime started = ros::WallTime::now();
    for (std::size_t k = first; k < last; ++k) {
      const double sample_s = pair_.reference.time_s[k];
      const double clock_s = std::max(sample_s, last_clock_s_.load());
      rosgraph_msgs::Clock clock;
      clock.clock = ros::Time().fromSec(clock_s);
      clock_pub_.publish(clock);
      const ros::Time stamp = ros::Time().fromSec(sample_s + stamp_offset_s);
      for (; next_scalar_ < scalar_.size() && scalar_.time_s[next_scalar_] <= stamp.toSec() + settings_.sample_period_s; ++next_scalar_) {
        mic::ScalarField f;
        f.header.stamp = ros::Time().fromSec(scalar_.time_s[next_scalar_]);
        f.header.frame_id = "scalar_frame";
        f.field = scalar_.value_nT[next_scalar_] * kTeslaPerNanotesla;
        scalar_pub_.publish(f);
      }
      if (reference && k % reference_stride_ == 0) reference_pub_.publish(field_message(stamp, "reference_frame", pair_.reference.values_nT.row(k), Eigen::Vector3d::Constant(0.01)));
      if (test && !temperature_C_.empty()) {
        sensor_msgs::Temperature t;
        t.header.stamp = stamp;
        t.header.frame_id = "test_frame";
        t.temperature = temperature_C_[k];
        t.variance = 0.0;  // unknown
        temperature_pub_.publish(t);
      }
      if (test) {
        test_pub_.publish(field_message(stamp, "test_frame", pair_.test.values_nT.row(k), test_noise_rms_nT_));
        for (auto& copy : test_copies_) {
          if (k % copy.stride != copy.first) continue;
          const mic::Readings& values = copy.values_nT.rows() > 0 ? copy.values_nT : pair_.test.values_nT;
          copy.publisher.publish(field_message(stamp, copy.frame_id, values.row(k), test_noise_rms_nT_));
        }
      }
      last_clock_s_ = clock_s;
      if (rate > 0.0 && (k - first) % 50 == 49) {
        const double due = static_cast<double>(k - first + 1) / rate;
        const double ahead = due - (ros::WallTime::now() - started).toSec();
        if (ahead > 0) ros::WallDuration(ahead).sleep();
      }
    }
  }

  /// Keeps /clock running for `seconds` of simulated time without data (lets timers fire).
  void tick_clock(double seconds, double step_s = 1.0) {
    for (double t = 0; t < seconds; t += step_s) {
      last_clock_s_ = last_clock_s_ + step_s;
      rosgraph_msgs::Clock clock;
      clock.clock = ros::Time().fromSec(last_clock_s_);
      clock_pub_.publish(clock);
      ros::WallDuration(0.0005).sleep();
    }
  }

  bool wait(const std::function<bool()>& done, double timeout_s) {
    return mic::test::wait_for_condition(mutex_, done, timeout_s);
  }

  /// wait(), advancing /clock by one second every 20 ms (timers and diagnostics run on it).
  bool wait_ticking(const std::function<bool()>& done, double timeout_s) {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
    while (ros::WallTime::now() < deadline) {
      if (wait(done, 0.0)) return true;
      tick_clock(1.0);
      ros::WallDuration(0.02).sleep();
    }
    return wait(done, 0.0);
  }

  /// Waits until the node's diagnostics count, for each {status name part, key, count}, at least
  /// that many messages (e.g. {"calibration_sim: reference", "messages", 2400}), advancing /clock
  /// a second every 20 ms so that the diagnostics go out: every message published before has then
  /// reached the node, and what follows meets no lag of one stream's connection behind the other's
  /// (the pairer ages samples in stamp time: a stamp jump while the other stream's samples are
  /// still in transit would leave them without partners).
  bool wait_received(const std::vector<std::tuple<std::string, std::string, std::size_t>>& counts, double timeout_s = 60.0) {
    return wait_ticking([&] {
      for (const auto& [part, key, count] : counts) {
        const DiagnosticRecord* d = latest_diagnostic(part);
        const auto it = d == nullptr ? std::map<std::string, std::string>::const_iterator() : d->values.find(key);
        if (d == nullptr || it == d->values.end() || std::stoull(it->second) < count) return false;
      }
      return true;
    }, timeout_s);
  }

  /// Advances /clock by `tick_s` (more than the nodes' diagnostic period), then waits (wall time,
  /// no further ticks) until every status whose name contains one of `parts` has been published
  /// by its node at a /clock later than the start of the ticks: the node has processed what was
  /// sent before this call and its diagnostics carry the final counters. Replaces "tick, then
  /// sleep a little and hope".
  bool wait_fresh_diagnostics(const std::vector<std::string>& parts, double tick_s, double timeout_s = 60.0) {
    const double after_s = last_clock_s_ + 0.5;
    tick_clock(tick_s);
    return wait([&] {
      for (const std::string& part : parts) {
        const DiagnosticRecord* d = latest_diagnostic(part);
        if (d == nullptr || d->node_time_s < after_s) return false;
      }
      return true;
    }, timeout_s);
  }

  // Recorded data; lock mutex() while reading when the spinner runs.
  std::mutex& mutex() { return mutex_; }
  const std::vector<mic::MagnetometerCalibration>& calibrations() const { return calibrations_; }
  const std::vector<CorrectedSample>& corrected(const std::string& topic) { return corrected_[topic]; }
  const std::vector<DiagnosticRecord>& diagnostics(const std::string& name) { return diagnostics_[name]; }
  /// Latest diagnostics of the status whose name contains `part`.
  const DiagnosticRecord* latest_diagnostic(const std::string& part) {
    for (auto& entry : diagnostics_) {
      if (entry.first.find(part) != std::string::npos && !entry.second.empty()) return &entry.second.back();
    }
    return nullptr;
  }
  std::vector<const DiagnosticRecord*> all_diagnostics(const std::string& part) {
    std::vector<const DiagnosticRecord*> out;
    for (auto& entry : diagnostics_) {
      if (entry.first.find(part) == std::string::npos) continue;
      for (const auto& r : entry.second) out.push_back(&r);
    }
    return out;
  }

  /// Prints the latest status of every diagnostic name (call with mutex() held).
  void dump_diagnostics() {
    for (const auto& entry : diagnostics_) {
      if (entry.second.empty()) continue;
      const DiagnosticRecord& r = entry.second.back();
      std::printf("[ diag ] %s: level %d: %s\n", entry.first.c_str(), r.level, r.message.c_str());
      for (const auto& kv : r.values) std::printf("[ diag ]     %s = %s\n", kv.first.c_str(), kv.second.c_str());
    }
  }

  const mic::SimulatedPair& pair() const { return pair_; }
  /// From sample `first` on, the test stream is `other`'s (a step change of the instrument).
  void splice_test(const mic::SimulatedPair& other, std::size_t first) {
    const auto rows = static_cast<Eigen::Index>(pair_.test.values_nT.rows()) - static_cast<Eigen::Index>(first);
    pair_.test.values_nT.bottomRows(rows) = other.test.values_nT.bottomRows(rows);
  }
  const mic::SimulationSettings& settings() const { return settings_; }
  double start_s() const { return pair_.reference.time_s.front(); }
  double last_clock_s() const { return last_clock_s_; }
  const Eigen::Vector3d& test_noise_rms_nT() const { return test_noise_rms_nT_; }

 private:
  static sensor_msgs::MagneticField field_message(const ros::Time& stamp, const std::string& frame,
                                                  const Eigen::Vector3d& value_nT, const Eigen::Vector3d& sigma_nT) {
    sensor_msgs::MagneticField m;
    m.header.stamp = stamp;
    m.header.frame_id = frame;
    m.magnetic_field.x = value_nT(0) * kTeslaPerNanotesla;
    m.magnetic_field.y = value_nT(1) * kTeslaPerNanotesla;
    m.magnetic_field.z = value_nT(2) * kTeslaPerNanotesla;
    for (int i = 0; i < 3; ++i) m.magnetic_field_covariance[4 * i] = std::pow(sigma_nT(i) * kTeslaPerNanotesla, 2);
    return m;
  }

  void on_calibration(const mic::MagnetometerCalibration::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    calibrations_.push_back(*m);
  }

  void on_corrected(const std::string& topic, const sensor_msgs::MagneticField::ConstPtr& m) {
    CorrectedSample s;
    s.stamp_s = m->header.stamp.toSec();
    s.field_nT = Eigen::Vector3d(m->magnetic_field.x, m->magnetic_field.y, m->magnetic_field.z) / kTeslaPerNanotesla;
    for (int k = 0; k < 9; ++k) s.covariance_nT2(k / 3, k % 3) = m->magnetic_field_covariance[k] / (kTeslaPerNanotesla * kTeslaPerNanotesla);
    s.frame_id = m->header.frame_id;
    std::lock_guard<std::mutex> lock(mutex_);
    corrected_[topic].push_back(s);
  }

  void on_diagnostics(const diagnostic_msgs::DiagnosticArray::ConstPtr& array) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& status : array->status) {
      DiagnosticRecord r;
      r.sim_time_s = last_clock_s_;
      r.node_time_s = array->header.stamp.toSec();
      r.level = status.level;
      r.message = status.message;
      for (const auto& kv : status.values) r.values[kv.key] = kv.value;
      diagnostics_[status.name].push_back(r);
    }
  }

  ros::NodeHandle nh_;
  mic::SimulationSettings settings_;
  mic::SimulatedPair pair_;
  ros::AsyncSpinner spinner_;
  std::string reference_topic_, test_topic_, calibration_topic_;
  ros::Publisher clock_pub_, reference_pub_, test_pub_, temperature_pub_, scalar_pub_;
  mic::ScalarRecord scalar_;     ///< published with the pair (empty: none)
  std::size_t next_scalar_ = 0;  ///< its first sample not yet published
  std::size_t reference_stride_ = 1;  ///< publish() sends reference samples 0, stride, 2 stride, ...
  mic::HutTemperatureSettings hut_;
  std::vector<double> temperature_C_;  ///< thermometer reading per sample, deg C (empty: none published)
  ros::Subscriber calibration_sub_, diagnostics_sub_;
  std::vector<ros::Subscriber> corrected_subs_, extra_calibration_subs_;
  struct TestCopy {
    ros::Publisher publisher;
    std::string frame_id;
    mic::Readings values_nT;  ///< empty: the pair's test readings
    std::size_t stride = 1, first = 0;  ///< publishes samples k with k % stride == first
  };
  std::vector<TestCopy> test_copies_;
  Eigen::Vector3d test_noise_rms_nT_ = Eigen::Vector3d::Zero();
  std::atomic<double> last_clock_s_{0.0};

  std::mutex mutex_;
  std::vector<mic::MagnetometerCalibration> calibrations_;
  std::map<std::string, std::vector<CorrectedSample>> corrected_;
  std::map<std::string, std::vector<mic::MagnetometerCalibration>> calibrations_of_;
  std::map<std::string, std::vector<DiagnosticRecord>> diagnostics_;
};

inline mic::SimulationSettings simulation(double duration_s, std::uint64_t seed, double period_s = 1.0) {
  mic::SimulationSettings s;
  s.duration_s = duration_s;
  s.sample_period_s = period_s;
  s.seed = seed;
  return s;
}

inline Eigen::Matrix3d matrix_of(const mic::MagnetometerCalibration& c) {
  Eigen::Matrix3d n;
  for (int k = 0; k < 9; ++k) n(k / 3, k % 3) = c.matrix[k];
  return n;
}

/// The bound, in 95 % half-widths of calibration c, that `parameters` of its estimates exceed
/// together with probability below 1e-6 (Bonferroni: each its two-sided 1e-6 / parameters quantile
/// of Student's t with the window's covariance_cells dof; a standard error is ci95 /
/// interval_quantile). Live tests check the truth only at such bounds: a test that fails by
/// chance is a defect; how well the estimates match the truth is the Monte Carlo programs' to say.
inline double truth_bound(const mic::MagnetometerCalibration& c, int parameters) {
  return mic::student_t_two_sided_quantile(1e-6 / parameters, c.covariance_cells) / c.interval_quantile;
}

inline Eigen::Matrix3d stderr_of(const mic::MagnetometerCalibration& c) {
  Eigen::Matrix3d s;
  for (int k = 0; k < 9; ++k) s(k / 3, k % 3) = std::sqrt(c.matrix_covariance[10 * k]);
  return s;
}

/// True when the nominal window [window_start, window_end] contains an epoch of [low, high].
inline bool overlaps(const mic::MagnetometerCalibration& c, double low_s, double high_s) {
  return c.window_start.toSec() <= high_s && c.window_end.toSec() >= low_s;
}

inline std::size_t value_of(const DiagnosticRecord* r, const std::string& key) {
  if (r == nullptr) return 0;
  const auto it = r->values.find(key);
  return it == r->values.end() ? 0 : static_cast<std::size_t>(std::stoull(it->second));
}

}  // namespace calibration_rostest
