// rostest with a real master: simulated reference and test streams (core simulator, known
// n_true, 1 Hz) published with a /clock much faster than real time into calibration_node and
// correction_node (launched by the .test files of this folder). One TEST per .test file, picked
// with --gtest_filter:
//   Calibration.Nominal        nominal.test       accepted calibration within 3 sigma of n_true,
//                                                 offset within its interval, YAML file, corrected
//                                                 stream equal to the clean field (absolute level),
//                                                 bad calibration files
//   Calibration.ChangeDetected test_calibration_change.test  scale ratio steps mid-run: change WARN
//                                                 after the step, never before
//   Calibration.ResumeAfterRestart test_calibration_resume.test  calibration_node started, killed
//                                                 and restarted by the test: the persisted
//                                                 calibration is published at once
//   Calibration.SilentTopic    silent_topic.test  test stream stops for 20 min
//   Calibration.TimeJump       time_jump.test     stamps jump forward by an hour
//   Calibration.Decimation10Hz decimation.test    10 Hz inputs decimated to 1 Hz in the node
//   Calibration.TwoInstruments two_instruments.test  a ~tests list: two test instruments, one node
//   Calibration.CorrectionFileReload correction_reload.test  correction_node's calibration file
//   Calibration.BadParameters  bad_parameters.test  impossible parameters: the node exits naming them
// Private parameters of the test node: the topic names and the calibration file of the launch.
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <magnetometer_insitu_calibration/MagnetometerCalibration.h>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <Eigen/LU>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/MagneticField.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

constexpr double kTeslaPerNanotesla = 1e-9;

struct DiagnosticRecord {
  double sim_time_s = 0.0;  ///< /clock when it arrived
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

std::string param(const std::string& name, const std::string& fallback = "") {
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
  void add_test_copy(const std::string& topic, const std::string& frame_id) {
    test_copies_.push_back({nh_.advertise<sensor_msgs::MagneticField>(topic, 100000), frame_id});
  }

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

  /// One raw test message (sample k of the simulation) with any stamp and frame_id.
  void publish_test_sample(std::size_t k, double stamp_s, const std::string& frame_id) {
    test_pub_.publish(field_message(ros::Time().fromSec(stamp_s), frame_id, pair_.test.values_nT.row(k), test_noise_rms_nT_));
  }

  std::size_t test_subscribers(std::size_t copy) const { return test_copies_.at(copy).first.getNumSubscribers(); }

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

  /// Publishes samples [first, last) of the simulation: /clock = start + k * period (never
  /// jumps), stamps = that + stamp_offset_s; reference and/or test. ~rate samples per wall second.
  void publish(std::size_t first, std::size_t last, bool reference, bool test, double stamp_offset_s = 0.0,
               double rate = -1.0) {
    if (rate < 0.0) {
      rate = 2500.0;  // samples per wall second; 0: as fast as possible
      ros::param::get("~rate", rate);
    }
    const ros::WallTime started = ros::WallTime::now();
    for (std::size_t k = first; k < last; ++k) {
      const double clock_s = pair_.reference.time_s[k];
      rosgraph_msgs::Clock clock;
      clock.clock = ros::Time().fromSec(clock_s);
      clock_pub_.publish(clock);
      const ros::Time stamp = ros::Time().fromSec(clock_s + stamp_offset_s);
      if (reference) reference_pub_.publish(field_message(stamp, "reference_frame", pair_.reference.values_nT.row(k), Eigen::Vector3d::Constant(0.01)));
      if (test) {
        test_pub_.publish(field_message(stamp, "test_frame", pair_.test.values_nT.row(k), test_noise_rms_nT_));
        for (auto& copy : test_copies_) {
          copy.first.publish(field_message(stamp, copy.second, pair_.test.values_nT.row(k), test_noise_rms_nT_));
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
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
    while (ros::WallTime::now() < deadline) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (done()) return true;
      }
      ros::WallDuration(0.02).sleep();
    }
    std::lock_guard<std::mutex> lock(mutex_);
    return done();
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
  ros::Publisher clock_pub_, reference_pub_, test_pub_;
  ros::Subscriber calibration_sub_, diagnostics_sub_;
  std::vector<ros::Subscriber> corrected_subs_, extra_calibration_subs_;
  std::vector<std::pair<ros::Publisher, std::string>> test_copies_;
  Eigen::Vector3d test_noise_rms_nT_ = Eigen::Vector3d::Zero();
  std::atomic<double> last_clock_s_{0.0};

  std::mutex mutex_;
  std::vector<mic::MagnetometerCalibration> calibrations_;
  std::map<std::string, std::vector<CorrectedSample>> corrected_;
  std::map<std::string, std::vector<mic::MagnetometerCalibration>> calibrations_of_;
  std::map<std::string, std::vector<DiagnosticRecord>> diagnostics_;
};

mic::SimulationSettings simulation(double duration_s, std::uint64_t seed, double period_s = 1.0) {
  mic::SimulationSettings s;
  s.duration_s = duration_s;
  s.sample_period_s = period_s;
  s.seed = seed;
  return s;
}

Eigen::Matrix3d matrix_of(const mic::MagnetometerCalibration& c) {
  Eigen::Matrix3d n;
  for (int k = 0; k < 9; ++k) n(k / 3, k % 3) = c.matrix[k];
  return n;
}

Eigen::Matrix3d stderr_of(const mic::MagnetometerCalibration& c) {
  Eigen::Matrix3d s;
  for (int k = 0; k < 9; ++k) s(k / 3, k % 3) = std::sqrt(c.matrix_covariance[10 * k]);
  return s;
}

/// True when the nominal window [window_start, window_end] contains an epoch of [low, high].
bool overlaps(const mic::MagnetometerCalibration& c, double low_s, double high_s) {
  return c.window_start.toSec() <= high_s && c.window_end.toSec() >= low_s;
}

std::size_t value_of(const DiagnosticRecord* r, const std::string& key) {
  if (r == nullptr) return 0;
  const auto it = r->values.find(key);
  return it == r->values.end() ? 0 : static_cast<std::size_t>(std::stoull(it->second));
}

}  // namespace

// ---------------------------------------------------------------------------------------------

TEST(Calibration, Nominal) {
  // 3 h 20 min of pairs at 1 Hz (~rate samples per wall second): windows of 3 h every 10 min ->
  // windows starting at t0 and t0 + 600 s. Then a burst of 5000 test samples alone, as fast as
  // the test can publish them, into the correction nodes (the load measurement: none dropped).
  const double window_s = 10800.0, step_s = 600.0;
  const std::size_t paired_samples = 12000, burst = 5000;
  mic::SimulationSettings sim = simulation(static_cast<double>(paired_samples + burst), 7);
  sim.test_offset_nT = Eigen::Vector3d(120.0, -75.0, 30.0);  // baseline of the test: the offset transfer
  Harness h(sim);
  const std::string corrected = param("corrected_topic", "/sim/corrected");
  const std::vector<std::string> bad_file_topics = {"/sim/corrected_malformed", "/sim/corrected_truncated"};
  h.subscribe_corrected(corrected);
  for (const auto& t : bad_file_topics) h.subscribe_corrected(t);
  const std::string file = param("calibration_file");
  ASSERT_FALSE(file.empty());
  std::remove(file.c_str());
  ASSERT_TRUE(h.wait_for_connections(1, 4)) << "nodes did not connect";

  const ros::WallTime started = ros::WallTime::now();
  const std::size_t n = h.pair().reference.size();
  h.publish(0, paired_samples, true, true);
  const double publish_wall_s = (ros::WallTime::now() - started).toSec();
  // Both windows estimated and in use by the correction nodes before the burst.
  const bool paired_done = h.wait([&] {
    if (h.calibrations().size() < 2) return false;
    for (const std::string& topic : {corrected, bad_file_topics[0], bad_file_topics[1]}) {
      const auto& c = h.corrected(topic);
      if (c.empty() || c.back().stamp_s < h.pair().reference.time_s[paired_samples - 1]) return false;
    }
    return true;
  }, 30.0);
  const ros::WallTime burst_started = ros::WallTime::now();
  h.publish(paired_samples, n, false, true, 0.0, /*rate=*/0.0);
  const double burst_wall_s = (ros::WallTime::now() - burst_started).toSec();
  // Everything processed: the corrected streams reached the last stamp, and the correction
  // nodes have counted every sample (the clock keeps ticking for their diagnostics).
  const double last_stamp = h.pair().reference.time_s.back();
  const bool done = paired_done && h.wait([&] {
    for (const std::string& topic : {corrected, bad_file_topics[0], bad_file_topics[1]}) {
      const auto& c = h.corrected(topic);
      if (c.empty() || c.back().stamp_s < last_stamp) return false;
    }
    return true;
  }, 30.0) && h.wait_ticking([&] {
    for (const char* node : {"correction_sim", "correction_malformed", "correction_truncated"}) {
      if (value_of(h.latest_diagnostic(node), "received") != n) return false;
    }
    return true;
  }, 30.0);
  const double burst_done_s = (ros::WallTime::now() - burst_started).toSec();
  h.tick_clock(30.0);  // a last round of diagnostics
  ros::WallDuration(0.3).sleep();
  std::lock_guard<std::mutex> lock(h.mutex());
  EXPECT_TRUE(paired_done) << "timed out waiting for the calibrations";
  EXPECT_TRUE(done) << "timed out waiting for the corrected burst";
  std::printf("[ timing ] published %zu pairs in %.2f s wall (%.0f samples/s per stream); burst of %zu test samples "
              "in %.3f s (%.0f samples/s), all corrected %.2f s after its start; total %.2f s\n",
              paired_samples, publish_wall_s, paired_samples / publish_wall_s, burst, burst_wall_s, burst / burst_wall_s,
              burst_done_s, (ros::WallTime::now() - started).toSec());

  // 1. Calibrations: two windows, accepted, within 4 standard errors of n_true (robust method:
  //    its intervals are ~20 % too narrow, docs/robust_estimation.md, so 3 se is ~2.5 true sigma).
  const auto& calibrations = h.calibrations();
  ASSERT_EQ(calibrations.size(), 2u);
  for (std::size_t i = 0; i < calibrations.size(); ++i) {
    const auto& c = calibrations[i];
    SCOPED_TRACE("calibration " + std::to_string(i));
    EXPECT_TRUE(c.accepted);
    EXPECT_EQ(c.quality, mic::MagnetometerCalibration::QUALITY_OK) << c.quality_text;
    EXPECT_EQ(c.test_name, "sim");
    EXPECT_EQ(c.reference_frame_id, "reference_frame");
    EXPECT_EQ(c.header.frame_id, "reference_frame");
    EXPECT_EQ(c.test_frame_id, "test_frame");
    EXPECT_DOUBLE_EQ(c.window_start.toSec(), h.start_s() + i * step_s);
    EXPECT_DOUBLE_EQ(c.window_end.toSec(), h.start_s() + i * step_s + window_s - 1.0);
    EXPECT_EQ(c.samples, 10800u);
    EXPECT_EQ(c.filled_samples, 0u);
    EXPECT_DOUBLE_EQ(c.sample_period, 1.0);
    EXPECT_DOUBLE_EQ(c.band_low_hz, 0.0002);
    EXPECT_DOUBLE_EQ(c.band_high_hz, 0.01);
    EXPECT_EQ(c.harmonic_first, 3u);    // ceil(0.0002 * 10800)
    EXPECT_EQ(c.harmonic_last, 108u);   // floor(0.01 * 10800)
    EXPECT_DOUBLE_EQ(c.gamma, 1.0);
    EXPECT_TRUE(c.trend_column);
    const Eigen::Matrix3d n_hat = matrix_of(c), se = stderr_of(c), n_true = h.pair().n_true;
    for (int k = 0; k < 9; ++k) {
      EXPECT_GT(se(k / 3, k % 3), 0.0);
      EXPECT_LE(std::abs(n_hat(k / 3, k % 3) - n_true(k / 3, k % 3)), 4.0 * se(k / 3, k % 3))
          << "entry " << k << ": " << n_hat(k / 3, k % 3) << " vs n_true " << n_true(k / 3, k % 3) << ", se "
          << se(k / 3, k % 3);
    }
    for (int l = 0; l < 3; ++l) {
      EXPECT_NEAR(c.scale_ratio[l], h.settings().scale_ratio(l), 4.0 * c.scale_ratio_ci95[l] / 1.96 + 1e-12);
      EXPECT_GT(c.coherence[l], 0.9);
      EXPECT_TRUE(std::isfinite(c.misalignment_deg[l]) && std::isfinite(c.nonorthogonality_deg[l]) &&
                  std::isfinite(c.axis_deviation_deg[l]) && std::isfinite(c.trend_ci95_nT_per_day[l]));
    }
    EXPECT_GT(c.condition_number, 1.0);
    // The offline CLI's estimator, its band and delay; the offset at the window end.
    EXPECT_EQ(c.method, "robust");
    EXPECT_GE(c.band_used_low_hz, 0.0002 - 1e-12);
    EXPECT_LE(c.band_used_high_hz, 0.01 + 1e-12);
    EXPECT_GT(c.band_used_high_hz, c.band_used_low_hz);
    EXPECT_TRUE(std::isfinite(c.delay_s) && c.delay_ci95_s > 0.0) << c.delay_s << " +- " << c.delay_ci95_s;
    EXPECT_LE(std::abs(c.delay_s), 1.5 * c.delay_ci95_s) << "simulated delay is 0";
    for (int l = 0; l < 3; ++l) {
      EXPECT_GT(c.offset_ci95_nT[l], 0.0);
      EXPECT_LE(std::abs(c.offset_nT[l] - sim.test_offset_nT(l)), 1.5 * c.offset_ci95_nT[l])
          << "offset " << l << ": " << c.offset_nT[l] << " +- " << c.offset_ci95_nT[l];
    }
    std::printf("[ result ] window %zu: delay %.3f +- %.3f s, offset %.3f %.3f %.3f nT (+- %.3f %.3f %.3f), set %.0f %.0f %.0f\n",
                i, c.delay_s, c.delay_ci95_s, c.offset_nT[0], c.offset_nT[1], c.offset_nT[2], c.offset_ci95_nT[0],
                c.offset_ci95_nT[1], c.offset_ci95_nT[2], sim.test_offset_nT(0), sim.test_offset_nT(1), sim.test_offset_nT(2));
    std::printf("[ result ] window %zu: max |n - n_true| / se = %.2f, se(n_xx) = %.2e\n", i,
                ((n_hat - n_true).cwiseAbs().array() / se.array()).maxCoeff(), se(0, 0));
  }

  // 2. The YAML file holds the latest accepted calibration and loads back equal.
  mic::MagnetometerCalibration loaded;
  ASSERT_NO_THROW(loaded = mic::load_calibration_file(file));
  std::string difference;
  EXPECT_TRUE(mic::calibrations_equal(loaded, calibrations.back(), &difference)) << "differs in " << difference;

  // 3. Corrected stream: nothing before the first calibration, then every sample (no drop), in
  //    the reference frame. Each corrected sample is r = n^-T (t - d) with the matrix and the
  //    offset d (at its window end) of one of the published calibrations (the one in use: they
  //    switch in order, once); it equals the clean field B within its published covariance,
  //    and, while one calibration is in use, B itself in absolute level: the mean difference
  //    within 4 noise sigma / sqrt(samples) plus the offset's stated 95 % half-width, the
  //    scatter about it within 1.5 x the simulated test noise.
  const auto& out = h.corrected(corrected);
  ASSERT_GT(out.size(), 100u);
  const double first_calibrated = calibrations.front().window_end.toSec();
  EXPECT_GT(out.front().stamp_s, first_calibrated) << "corrected data before any calibration existed";
  const auto first_index = static_cast<std::size_t>(std::llround(out.front().stamp_s - h.start_s()));
  EXPECT_EQ(out.size(), n - first_index) << "corrected samples missing after the first one";
  std::vector<Eigen::Matrix3d> inverse_transposed;
  std::vector<Eigen::Vector3d> offsets;
  for (const auto& c : calibrations) {
    inverse_transposed.push_back(matrix_of(c).inverse().transpose());
    offsets.emplace_back(c.offset_nT[0], c.offset_nT[1], c.offset_nT[2]);
  }
  std::vector<std::vector<Eigen::Vector3d>> errors(calibrations.size());
  std::size_t outside = 0, unexplained = 0, in_use = 0;
  for (std::size_t i = 0; i < out.size(); ++i) {
    const auto k = static_cast<std::size_t>(std::llround(out[i].stamp_s - h.start_s()));
    ASSERT_LT(k, n);
    EXPECT_EQ(k, first_index + i);
    EXPECT_EQ(out[i].frame_id, "reference_frame");
    const Eigen::Vector3d t = h.pair().test.values_nT.row(k).transpose();
    std::size_t which = calibrations.size();
    for (std::size_t c = in_use; c < calibrations.size() && which == calibrations.size(); ++c) {
      if ((out[i].field_nT - inverse_transposed[c] * (t - offsets[c])).norm() < 1e-6) which = c;
    }
    if (which == calibrations.size()) {
      ++unexplained;
      continue;
    }
    in_use = which;
    const Eigen::Vector3d error = out[i].field_nT - h.pair().field_nT.row(k).transpose();
    for (int j = 0; j < 3; ++j) outside += std::abs(error(j)) > 5.0 * std::sqrt(out[i].covariance_nT2(j, j));
    errors[which].push_back(error);
  }
  EXPECT_EQ(unexplained, 0u) << "corrected samples that are not n^-T (t - d) for the calibration in use";
  EXPECT_EQ(outside, 0u) << "corrected values outside 5 sigma of their published covariance";
  for (std::size_t c = 0; c < errors.size(); ++c) {
    if (errors[c].empty()) continue;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero(), rms = Eigen::Vector3d::Zero();
    for (const auto& e : errors[c]) mean += e;
    mean /= static_cast<double>(errors[c].size());
    for (const auto& e : errors[c]) rms += (e - mean).cwiseAbs2();
    rms = (rms / static_cast<double>(errors[c].size())).cwiseSqrt();
    for (int j = 0; j < 3; ++j) {
      EXPECT_LT(rms(j), 1.5 * h.test_noise_rms_nT()(j)) << "calibration " << c << ", component " << j;
      const double allowed = 4.0 * h.test_noise_rms_nT()(j) / std::sqrt(static_cast<double>(errors[c].size())) +
                             calibrations[c].offset_ci95_nT[j];
      EXPECT_LE(std::abs(mean(j)), allowed) << "calibration " << c << ", component " << j
                                            << ": corrected minus clean field, mean " << mean(j) << " nT";
      // The stated interval of d alone is wide (mean field x se(n)), but d's error and n's cancel
      // near the window's field: the absolute level is far better than that (the set baseline
      // is 30-120 nT; without the offset the mean difference would be about that).
      EXPECT_LT(std::abs(mean(j)), 1.0) << "calibration " << c << ", component " << j;
    }
    std::printf("[ result ] %zu samples corrected with calibration %zu: offset %.2f %.2f %.2f nT "
                "(1 sigma %.2f %.2f %.2f nT), rms about it %.4f %.4f %.4f nT (test noise %.4f %.4f %.4f nT)\n",
                errors[c].size(), c, mean(0), mean(1), mean(2), std::sqrt(out.back().covariance_nT2(0, 0)),
                std::sqrt(out.back().covariance_nT2(1, 1)), std::sqrt(out.back().covariance_nT2(2, 2)), rms(0), rms(1),
                rms(2), h.test_noise_rms_nT()(0), h.test_noise_rms_nT()(1), h.test_noise_rms_nT()(2));
  }
  EXPECT_FALSE(errors.back().empty()) << "the latest calibration was never used";

  // 4. Every raw sample is accounted for by the correction node.
  const DiagnosticRecord* d = h.latest_diagnostic("correction_sim");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(value_of(d, "received"), n);
  EXPECT_EQ(value_of(d, "published"), out.size());
  EXPECT_EQ(value_of(d, "dropped, no calibration"), n - out.size());
  EXPECT_EQ(d->values.at("calibration source").rfind("topic", 0), 0u);
  EXPECT_NE(d->values.at("calibration window").find("T"), std::string::npos);
  const DiagnosticRecord* cal = h.latest_diagnostic("calibration_sim: sim");
  ASSERT_NE(cal, nullptr);
  EXPECT_EQ(value_of(cal, "windows accepted"), 2u);
  EXPECT_EQ(value_of(cal, "paired"), paired_samples);
  EXPECT_EQ(value_of(cal, "late") + value_of(cal, "duplicates"), 0u);

  // 5. Correction nodes started with a malformed / half-written file: an error in the
  //    diagnostics, nothing published until a calibration arrives on the topic, then correcting.
  for (const std::string& node : {std::string("correction_malformed"), std::string("correction_truncated")}) {
    SCOPED_TRACE(node);
    bool error_seen = false;
    for (const DiagnosticRecord* r : h.all_diagnostics(node)) {
      error_seen |= r->level == 2 && r->message.find("calibration file unusable") != std::string::npos &&
                    r->message.find(".yaml") != std::string::npos;
    }
    EXPECT_TRUE(error_seen) << "no error diagnostic for the bad calibration file";
    const auto& bad = h.corrected("/sim/" + std::string(node == "correction_malformed" ? "corrected_malformed" : "corrected_truncated"));
    ASSERT_FALSE(bad.empty());
    EXPECT_GT(bad.front().stamp_s, first_calibrated);
    const DiagnosticRecord* last = h.latest_diagnostic(node);
    ASSERT_NE(last, nullptr);
    EXPECT_EQ(value_of(last, "received"), n) << "samples dropped under load";
    EXPECT_EQ(value_of(last, "published"), bad.size());
  }
}

// ---------------------------------------------------------------------------------------------

TEST(Calibration, SilentTopic) {
  // Windows of 30 min every 5 min. The test stream stops from t0 + 2400 s to t0 + 3600 s.
  const double silent_first = 2400.0, silent_end = 3600.0;
  Harness h(simulation(7000.0, 11));
  ASSERT_TRUE(h.wait_for_connections(1, 2)) << "nodes did not connect";
  const double t0 = h.start_s();
  h.publish(0, 2400, true, true);
  h.publish(2400, 3600, true, false);  // test topic silent for 20 min (reference and /clock go on)
  // The silence shows in the diagnostics while it lasts (silent_timeout 300 s, diagnostics every
  // 5 s; a timeout much shorter than the arrival skew of the topics at 2500x real time, about
  // 0.1 s wall = 250 s simulated, would also warn about the reference now and then).
  EXPECT_TRUE(h.wait([&] {
    for (const DiagnosticRecord* r : h.all_diagnostics("calibration_sim: sim")) {
      if (r->level == 1 && r->message.find("test topic silent") != std::string::npos) return true;
    }
    return false;
  }, 10.0)) << "no silence warning";
  {
    std::lock_guard<std::mutex> lock(h.mutex());
    const DiagnosticRecord* reference = h.latest_diagnostic("calibration_sim: reference");
    ASSERT_NE(reference, nullptr);
    EXPECT_EQ(reference->level, 0) << reference->message;
  }
  h.publish(3600, 7000, true, true);
  const double last_window_start = t0 + 5100.0;  // [5100, 6900): the last complete window
  EXPECT_TRUE(h.wait([&] {
    return !h.calibrations().empty() && h.calibrations().back().window_start.toSec() >= last_window_start;
  }, 20.0));
  h.tick_clock(20.0);
  ros::WallDuration(0.2).sleep();

  std::lock_guard<std::mutex> lock(h.mutex());
  std::size_t accepted_before = 0, flagged_across = 0, accepted_after = 0;
  for (const auto& c : h.calibrations()) {
    const double start = c.window_start.toSec() - t0;
    if (overlaps(c, t0 + silent_first, t0 + silent_end - 1.0)) {
      EXPECT_FALSE(c.accepted) << "window starting at t0 + " << start << " s accepted across the silence";
      EXPECT_EQ(c.quality, mic::MagnetometerCalibration::QUALITY_GAPS) << c.quality_text;
      EXPECT_GT(c.filled_samples, 0u);
      ++flagged_across;
    } else if (c.window_end.toSec() < t0 + silent_first) {
      accepted_before += c.accepted;
    } else {
      accepted_after += c.accepted;
    }
  }
  // Windows starting 900..3300 s overlap the silence (the ones wholly inside it have no data: skipped).
  EXPECT_EQ(flagged_across, 9u);
  EXPECT_EQ(accepted_before, 3u);  // [0, 1800), [300, 2100), [600, 2400)
  EXPECT_EQ(accepted_after, 6u);   // [3600, 5400) .. [5100, 6900)
  const DiagnosticRecord* cal = h.latest_diagnostic("calibration_sim: sim");
  ASSERT_NE(cal, nullptr);
  EXPECT_EQ(cal->message.find("silent"), std::string::npos) << "still silent after the stream resumed";
  EXPECT_GT(value_of(cal, "unpaired reference"), 1000u);
  EXPECT_EQ(value_of(cal, "windows skipped (no data)"), 0u);
}

// ---------------------------------------------------------------------------------------------

TEST(Calibration, TimeJump) {
  // Both streams' stamps jump forward by one hour at t0 + 2400 s (the clock does not).
  const double jump_s = 3600.0;
  Harness h(simulation(4801.0, 13));
  h.subscribe_corrected(param("corrected_topic", "/sim/corrected"));
  ASSERT_TRUE(h.wait_for_connections(1, 2)) << "nodes did not connect";
  const double t0 = h.start_s();
  h.publish(0, 2400, true, true);
  h.publish(2400, 4801, true, true, jump_s);  // stamps t0 + 6000 .. t0 + 8400
  EXPECT_TRUE(h.wait([&] {
    return !h.calibrations().empty() && h.calibrations().back().window_start.toSec() >= t0 + 6600.0;
  }, 20.0));
  h.tick_clock(20.0);
  ros::WallDuration(0.2).sleep();

  {
  std::lock_guard<std::mutex> lock(h.mutex());
  std::size_t accepted_before = 0, flagged_across = 0, accepted_after = 0;
  for (const auto& c : h.calibrations()) {
    if (overlaps(c, t0 + 2400.0, t0 + 2400.0 + jump_s - 1.0)) {
      EXPECT_FALSE(c.accepted) << "window " << c.window_start.toSec() - t0 << " s spanning the jump accepted";
      ++flagged_across;
    } else if (c.window_end.toSec() < t0 + 2400.0) {
      accepted_before += c.accepted;
    } else {
      accepted_after += c.accepted;
    }
  }
  EXPECT_EQ(accepted_before, 3u);   // [0, 1800) .. [600, 2400)
  EXPECT_GE(flagged_across, 10u);   // [900, 2700) .. [2100, 3900) and [4500, 6300) .. [5700, 7500)
  EXPECT_EQ(accepted_after, 3u);    // [6000, 7800), [6300, 8100), [6600, 8400)
  const DiagnosticRecord* reference = h.latest_diagnostic("calibration_sim: reference");
  const DiagnosticRecord* test = h.latest_diagnostic("calibration_sim: sim");
  ASSERT_NE(reference, nullptr);
  ASSERT_NE(test, nullptr);
  EXPECT_EQ(value_of(reference, "stamp jumps forward"), 1u);
  EXPECT_EQ(value_of(test, "test stamp jumps forward"), 1u);
  // Pairs around the jump can be lost: a sample whose partner is still in transit when the other
  // stream's stamps are already pairing_max_wait (600 s) ahead is dropped (StreamPairer ages
  // samples in stamp time). At most the transport jitter's worth of samples.
  EXPECT_GE(value_of(test, "paired"), 4700u);
  // The correction node went on across the jump.
  const auto& out = h.corrected(param("corrected_topic", "/sim/corrected"));
  ASSERT_FALSE(out.empty());
  EXPECT_GE(out.back().stamp_s, t0 + 8400.0);
  }

  // Correction policy, with the last calibration (window t0 + 6600 .. 8399 s) in use:
  // 5 samples of another frame_id are not corrected (counted); 5 samples stamped before the
  // window are corrected with it (counted); neither disturbs the calibration node beyond a
  // stray stamp and, for the second old sample in a row, a restart of its pairing.
  const std::string corrected = param("corrected_topic", "/sim/corrected");
  std::size_t corrected_before = 0, received_before = 0;
  {
    std::lock_guard<std::mutex> lock(h.mutex());
    corrected_before = h.corrected(corrected).size();
    received_before = value_of(h.latest_diagnostic("correction_sim"), "received");
  }
  for (std::size_t k = 0; k < 5; ++k) h.publish_test_sample(4000 + k, t0 + 8401.0 + k, "another_frame");
  for (std::size_t k = 0; k < 5; ++k) h.publish_test_sample(100 + k, t0 + 100.0 + k, "test_frame");
  EXPECT_TRUE(h.wait_ticking([&] {
    return value_of(h.latest_diagnostic("correction_sim"), "received") == received_before + 10 &&
           h.corrected(corrected).size() == corrected_before + 5;
  }, 10.0));
  std::lock_guard<std::mutex> lock(h.mutex());
  const DiagnosticRecord* d = h.latest_diagnostic("correction_sim");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(value_of(d, "dropped, frame_id mismatch"), 5u);
  EXPECT_EQ(value_of(d, "corrected, before window"), 5u);
  const auto& out = h.corrected(corrected);
  ASSERT_EQ(out.size(), corrected_before + 5);
  for (std::size_t i = corrected_before; i < out.size(); ++i) {
    EXPECT_DOUBLE_EQ(out[i].stamp_s, t0 + 100.0 + (i - corrected_before));
    EXPECT_EQ(out[i].frame_id, "reference_frame");
  }
}

// ---------------------------------------------------------------------------------------------

TEST(Calibration, Decimation10Hz) {
  // 10 Hz inputs (input_period 0.1 s), low-passed and decimated to 1 Hz in calibration_node;
  // windows of 30 min every 5 min. The decimator's first output comes h = 3.9 s after the first
  // sample, so the first window starts at t0 + 300 s.
  Harness h(simulation(2500.0, 17, 0.1));
  ASSERT_TRUE(h.wait_for_connections(1, 1)) << "nodes did not connect";
  const double t0 = h.start_s();
  const ros::WallTime started = ros::WallTime::now();
  const std::size_t n = h.pair().reference.size();
  h.publish(0, n, true, true);
  const double publish_wall_s = (ros::WallTime::now() - started).toSec();
  EXPECT_TRUE(h.wait([&] { return h.calibrations().size() >= 2; }, 20.0));
  h.tick_clock(20.0);
  ros::WallDuration(0.2).sleep();
  std::printf("[ timing ] published %zu pairs at 10 Hz in %.2f s wall (%.0f samples/s per stream)\n", n, publish_wall_s,
              n / publish_wall_s);

  std::lock_guard<std::mutex> lock(h.mutex());
  ASSERT_EQ(h.calibrations().size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const auto& c = h.calibrations()[i];
    SCOPED_TRACE("calibration " + std::to_string(i));
    EXPECT_TRUE(c.accepted) << c.quality_text;
    EXPECT_DOUBLE_EQ(c.window_start.toSec(), t0 + 300.0 * (i + 1));
    EXPECT_DOUBLE_EQ(c.sample_period, 1.0);
    EXPECT_EQ(c.samples, 1800u);
    EXPECT_EQ(c.filled_samples, 0u);
    const Eigen::Matrix3d n_hat = matrix_of(c), se = stderr_of(c), n_true = h.pair().n_true;
    for (int k = 0; k < 9; ++k) {
      EXPECT_LE(std::abs(n_hat(k / 3, k % 3) - n_true(k / 3, k % 3)), 3.0 * se(k / 3, k % 3)) << "entry " << k;
    }
    std::printf("[ result ] 10 Hz window %zu: max |n - n_true| / se = %.2f\n", i,
                ((n_hat - n_true).cwiseAbs().array() / se.array()).maxCoeff());
  }
  const DiagnosticRecord* cal = h.latest_diagnostic("calibration_sim: sim");
  ASSERT_NE(cal, nullptr);
  EXPECT_EQ(cal->values.at("decimating"), "True");
  EXPECT_EQ(value_of(cal, "paired"), n);
}

// ---------------------------------------------------------------------------------------------

TEST(Calibration, TwoInstruments) {
  // One calibration_node with a ~tests list of two instruments (the second one sees the same
  // simulated test readings under another frame_id): one calibration topic and file each.
  Harness h(simulation(2401.0, 19));
  h.add_test_copy("/sim/test_b/magnetic_field", "test_b_frame");
  h.subscribe_calibration("/sim/b/calibration");
  ASSERT_TRUE(h.wait_for_connections(1, 1)) << "nodes did not connect";
  ASSERT_TRUE(h.wait([&] { return h.test_subscribers(0) >= 1; }, 20.0));
  h.publish(0, 2401, true, true);
  EXPECT_TRUE(h.wait([&] {
    return h.calibrations().size() >= 3 && h.calibrations_of("/sim/b/calibration").size() >= 3;
  }, 20.0));
  std::lock_guard<std::mutex> lock(h.mutex());
  const auto& a = h.calibrations();
  const auto& b = h.calibrations_of("/sim/b/calibration");
  ASSERT_EQ(a.size(), 3u);  // [0, 1800), [300, 2100), [600, 2400)
  ASSERT_EQ(b.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_TRUE(a[i].accepted) << a[i].quality_text;
    EXPECT_TRUE(b[i].accepted) << b[i].quality_text;
    EXPECT_EQ(a[i].test_name, "a");
    EXPECT_EQ(b[i].test_name, "b");
    EXPECT_EQ(a[i].test_frame_id, "test_frame");
    EXPECT_EQ(b[i].test_frame_id, "test_b_frame");
    EXPECT_EQ(a[i].window_start, b[i].window_start);
    for (int k = 0; k < 9; ++k) EXPECT_EQ(a[i].matrix[k], b[i].matrix[k]);  // same data, same estimate
  }
  for (const std::string& file : {param("file_a"), param("file_b")}) {
    SCOPED_TRACE(file);
    mic::MagnetometerCalibration loaded;
    ASSERT_NO_THROW(loaded = mic::load_calibration_file(file));
    EXPECT_EQ(loaded.window_start, a.back().window_start);
    std::remove(file.c_str());
  }
}

// ---------------------------------------------------------------------------------------------

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
  ASSERT_TRUE(h.wait([&] { return value_of(diagnostic(), "received") == 100; }, 10.0));
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
  mic::write_file_atomically(file, mic::calibration_to_yaml(c, "test"));
  ASSERT_TRUE(h.wait([&] {
    const DiagnosticRecord* d = diagnostic();
    return d != nullptr && d->values.count("calibration source") && d->values.at("calibration source") == "file " + file;
  }, 10.0)) << "the file was not adopted";
  h.publish(100, 200, false, true, 0.0, 1000.0);
  ASSERT_TRUE(h.wait([&] { return h.corrected(corrected).size() == 100; }, 10.0));

  // 3. A half-written file (not atomic): refused, the calibration in use is kept.
  const std::string text = mic::calibration_to_yaml(c, "test");
  {
    std::ofstream out(file, std::ios::trunc);
    out << text.substr(0, text.size() / 2);
  }
  ASSERT_TRUE(h.wait([&] {
    const DiagnosticRecord* d = diagnostic();
    return d != nullptr && d->message.find("calibration file unusable") != std::string::npos;
  }, 10.0)) << "no diagnostic for the half-written file";
  {
    std::lock_guard<std::mutex> lock(h.mutex());
    EXPECT_EQ(diagnostic()->level, 1) << diagnostic()->message;  // a warning: still correcting
    EXPECT_EQ(diagnostic()->values.at("calibration source"), "file " + file);
  }
  h.publish(200, 300, false, true, 0.0, 1000.0);
  ASSERT_TRUE(h.wait([&] { return h.corrected(corrected).size() == 200; }, 10.0));

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
  }, 10.0)) << "the new file was not adopted";
  h.publish(300, 400, false, true, 0.0, 1000.0);
  ASSERT_TRUE(h.wait([&] { return h.corrected(corrected).size() == 300; }, 10.0));

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

// ---------------------------------------------------------------------------------------------

namespace {

struct RunResult {
  int exit_code = -1;
  std::string output;
};

RunResult run(const std::string& command) {
  RunResult r;
  FILE* pipe = ::popen(("timeout 30 " + command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return r;
  char buffer[4096];
  std::size_t got;
  while ((got = std::fread(buffer, 1, sizeof(buffer), pipe)) > 0) r.output.append(buffer, got);
  const int status = ::pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

}  // namespace

TEST(Calibration, BadParameters) {
  const std::string calibration = CALIBRATION_NODE_PATH, correction = CORRECTION_NODE_PATH;
  const std::string ok = " _reference_topic:=/r _test_topic:=/t _calibration_file:=/tmp/unused.yaml";
  struct Case {
    std::string command, expected;
  };
  const std::vector<Case> cases = {
      {calibration + " __name:=bad_step" + ok + " _window:=3600 _step:=7200", "parameter ~step: (7200 s) is longer than ~window"},
      {calibration + " __name:=bad_window" + ok + " _window:=-3600", "parameter ~window: must be > 0 s"},
      {calibration + " __name:=bad_band" + ok + " _band_low:=0.01 _band_high:=0.005", "parameter ~band_high:"},
      {calibration + " __name:=bad_short" + ok + " _window:=600 _step:=60", "parameter ~window: (600 s) holds only"},
      {calibration + " __name:=bad_type" + ok + " _step:=ten", "parameter ~step: must be a number"},
      {calibration + " __name:=no_reference _test_topic:=/t _calibration_file:=/tmp/x.yaml", "parameter ~reference_topic: is required"},
      {calibration + " __name:=no_file _reference_topic:=/r _test_topic:=/t", "parameter ~calibration_file: is required"},
      {calibration + " __name:=bad_tolerance" + ok + " _pairing_tolerance:=0.7", "parameter ~pairing_tolerance:"},
      {calibration + " __name:=bad_method" + ok + " _method:=fast", "parameter ~method:"},
      {calibration + " __name:=bad_eiv" + ok + " _eiv:=deming", "parameter ~eiv:"},
      {calibration + " __name:=bad_noise" + ok + " _reference_noise_pT:=-10", "parameter ~reference_noise_pT:"},
      {calibration + " __name:=bad_ratio" + ok + " _eiv_noise_ratio:=-1", "parameter ~eiv_noise_ratio:"},
      {calibration + " __name:=bad_delay" + ok + " _estimate_delay:=false", "parameter ~correct_delay:"},
      {correction + " __name:=bad_offset _test_topic:=/t _apply_offset:=maybe", "parameter ~apply_offset:"},
      {correction + " __name:=no_test_topic", "parameter ~test_topic: is required"},
      {correction + " __name:=bad_queue _test_topic:=/t _queue_size:=0", "parameter ~queue_size:"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.command);
    const RunResult r = run(c.command);
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_NE(r.output.find(c.expected), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("FATAL"), std::string::npos) << r.output;
  }
}

// ---------------------------------------------------------------------------------------------

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
  }, 60.0);
  h.tick_clock(120.0);
  ros::WallDuration(0.3).sleep();
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
  EXPECT_GE(value_of(last, "calibration changes detected"), 1u);
  // The windows wholly after the step measure the new scale ratio.
  const auto& last_window = h.calibrations().back();
  EXPECT_GE(last_window.window_start.toSec(), change_s);
  EXPECT_NEAR(last_window.scale_ratio[0], after.scale_ratio(0), 3.0 * last_window.scale_ratio_ci95[0] / 1.96 + 1e-12);
}

// ---------------------------------------------------------------------------------------------

namespace {

/// Starts `program` with `arguments` (stdout/stderr shared with the test); returns its pid.
pid_t spawn(const std::string& program, const std::vector<std::string>& arguments) {
  std::vector<std::string> all{program};
  all.insert(all.end(), arguments.begin(), arguments.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(&a[0]);
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::execv(program.c_str(), argv.data());
    ::_exit(127);
  }
  return pid;
}

/// SIGINT (as roslaunch does), then waits up to timeout_s wall seconds; SIGKILL if it hangs.
/// Returns true when it exited by itself.
bool stop_process(pid_t pid, double timeout_s = 15.0) {
  if (pid <= 0) return false;
  ::kill(pid, SIGINT);
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  int status = 0;
  while (ros::WallTime::now() < deadline) {
    if (::waitpid(pid, &status, WNOHANG) == pid) return true;
    ros::WallDuration(0.05).sleep();
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, &status, 0);
  return false;
}

/// A spawned node, stopped when the test returns (also on a failed ASSERT).
struct Child {
  pid_t pid = -1;
  ~Child() { stop(); }
  bool stop() {
    const bool clean = stop_process(pid);
    pid = -1;
    return clean;
  }
};

}  // namespace

TEST(Calibration, ResumeAfterRestart) {
  // The test starts calibration_node itself (windows of 30 min every 15 min), feeds it 1 h of
  // pairs until windows are accepted and written, stops it (SIGINT), and starts it again with the
  // same parameters and no data: the restarted node publishes the persisted calibration (latched)
  // at once, equal to the file and to the last one the first instance published, and reports it
  // loaded from file.
  const std::string file = param("calibration_file");
  ASSERT_FALSE(file.empty());
  std::remove(file.c_str());
  const std::vector<std::string> arguments = {
      "__name:=resume_calibration_node", "_reference_topic:=" + param("reference_topic"), "_test_topic:=" + param("test_topic"),
      "_calibration_topic:=" + param("calibration_topic"), "_calibration_file:=" + file, "_test_name:=resume",
      "_window:=1800", "_step:=900", "_silent_timeout:=300", "_diagnostic_period:=5"};
  Harness h(simulation(3700.0, 31));
  Child first{spawn(CALIBRATION_NODE_PATH, arguments)};
  ASSERT_GT(first.pid, 0);
  ASSERT_TRUE(h.wait_for_connections(1, 1)) << "first calibration_node did not connect";
  h.publish(0, h.pair().reference.size(), true, true);
  const bool accepted = h.wait_ticking([&] {
    const DiagnosticRecord* d = h.latest_diagnostic("resume_calibration_node: resume");
    return h.calibrations().size() >= 2 && d != nullptr && value_of(d, "windows estimated") == h.calibrations().size();
  }, 60.0);
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

  // Restart: no data, no clock advance until the calibration is in.
  std::size_t before_restart = 0;
  {
    std::lock_guard<std::mutex> lock(h.mutex());
    before_restart = h.calibrations().size();
  }
  const ros::WallTime restarted = ros::WallTime::now();
  Child second{spawn(CALIBRATION_NODE_PATH, arguments)};
  ASSERT_GT(second.pid, 0);
  const bool resumed = h.wait([&] { return h.calibrations().size() > before_restart; }, 20.0);
  const double resume_wall_s = (ros::WallTime::now() - restarted).toSec();
  // Diagnostics of the restarted node (they run on /clock).
  const bool diagnosed = h.wait_ticking([&] {
    const DiagnosticRecord* d = h.latest_diagnostic("resume_calibration_node: resume");
    return d != nullptr && d->values.count("loaded from file") && d->values.at("loaded from file") == "True";
  }, 20.0);
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
  EXPECT_TRUE(second_stopped);
  std::remove(file.c_str());
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "calibration_rostest");
  ros::NodeHandle keep_alive;  // roscpp (and its logging) stays up for every TEST
  return RUN_ALL_TESTS();
}
