// bench_correction_probe: correction latency of correction_node, measured end to end through
// ROS (scripts/bench_correction_latency.sh builds and runs it; like bench_publisher it is not
// part of the default build: scripts/bench_ros_common.sh compiles it on demand).
//
// The probe plays the test instrument and the calibration node of one pair:
//   - it publishes one valid, accepted calibration (latched) on --calibration-topic, so that
//     correction_node corrects from the first sample on;
//   - it publishes test samples (sensor_msgs/MagneticField, tesla, covariance set as a LEMI-025
//     driver does) on --test-topic at --rate Hz, paced on the steady clock; each sample's stamp
//     is unique (start + k / rate) and the steady-clock time just before publish() is kept;
//   - it subscribes to --corrected-topic (tcp_nodelay, its own spinner thread) and, for each
//     corrected sample, looks up the publish time by the stamp:
//       latency = arrival of the corrected sample - publication of the raw test sample.
// Before timing it waits for both connections and for a first corrected sample (the calibration
// adopted), then publishes --warmup s that are not counted. At the end it prints
//   latency_ms samples=N received=N lost=N median=.. p90=.. p99=.. max=.. mean=.. late_ticks=N
// (late_ticks: samples published more than 10 ms behind their schedule: the probe itself
// was starved of CPU) and, with --csv FILE, one row per sample (k, stamp, latency_ms or nan).
// With --load-nodelet NAME the probe is also the nodelet manager: it loads the correction_node
// nodelet (magnetometer_insitu_calibration/correction_node, the same class, parameters under
// NAME) into its own process, so that the samples reach it and come back in-process (no TCP).
//
//   bench_correction_probe --rate 10 --duration 120 [--warmup 5] [--test-topic /probe/test]
//                          [--corrected-topic /probe/corrected] [--calibration-topic /probe/calibration]
//                          [--frame probe_test] [--csv latencies.csv] [--load-nodelet /probe_correction]
#include <magnetometer_insitu_calibration/MagnetometerCalibration.h>
#include <nodelet/loader.h>
#include <ros/ros.h>
#include <sensor_msgs/MagneticField.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto i = static_cast<std::size_t>(pos);
  const double f = pos - static_cast<double>(i);
  return i + 1 < v.size() ? v[i] * (1.0 - f) + v[i + 1] * f : v[i];
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "bench_correction_probe", ros::init_options::AnonymousName);
  double rate = 10.0, duration = 120.0, warmup = 5.0;
  std::string test_topic = "/probe/test", corrected_topic = "/probe/corrected",
              calibration_topic = "/probe/calibration", frame = "probe_test", csv_path, nodelet_name;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string o = argv[i];
    const char* v = argv[i + 1];
    if (o == "--rate") rate = std::atof(v);
    else if (o == "--duration") duration = std::atof(v);
    else if (o == "--warmup") warmup = std::atof(v);
    else if (o == "--test-topic") test_topic = v;
    else if (o == "--corrected-topic") corrected_topic = v;
    else if (o == "--calibration-topic") calibration_topic = v;
    else if (o == "--frame") frame = v;
    else if (o == "--csv") csv_path = v;
    else if (o == "--load-nodelet") nodelet_name = v;
    else {
      std::fprintf(stderr, "bench_correction_probe: unknown option %s\n", o.c_str());
      return 2;
    }
  }
  if (!(rate > 0) || !(duration > 0) || !(warmup >= 0)) {
    std::fprintf(stderr, "bench_correction_probe: impossible option\n");
    return 2;
  }
  const double period = 1.0 / rate;
  const auto warm_ticks = static_cast<std::size_t>(std::llround(warmup * rate));
  const auto timed_ticks = static_cast<std::size_t>(std::llround(duration * rate));
  const std::size_t total = warm_ticks + timed_ticks;
  // Index k of a sample: stamp = start + k period. The start is a whole second of wall time.
  const ros::Time start(std::floor(ros::WallTime::now().toSec()) + 10.0);

  std::vector<Clock::time_point> published(total);
  std::unique_ptr<std::atomic<std::int64_t>[]> arrived(new std::atomic<std::int64_t>[total]);
  for (std::size_t k = 0; k < total; ++k) arrived[k].store(-1);
  std::atomic<std::size_t> corrected_count{0}, foreign{0}, priming_seen{0};
  const Clock::time_point t_ref = Clock::now();

  ros::NodeHandle nh;
  // In-process correction: this process is its nodelet manager (no ROS services: a plain loader).
  std::unique_ptr<nodelet::Loader> manager;
  if (!nodelet_name.empty()) {
    manager = std::make_unique<nodelet::Loader>(false);
    if (!manager->load(nodelet_name, "magnetometer_insitu_calibration/correction_node", nodelet::M_string(),
                       nodelet::V_string())) {
      std::fprintf(stderr, "bench_correction_probe: cannot load the correction_node nodelet as %s\n", nodelet_name.c_str());
      return 1;
    }
  }
  ros::Subscriber sub = nh.subscribe<sensor_msgs::MagneticField>(
      corrected_topic, 100000,
      [&](const sensor_msgs::MagneticField::ConstPtr& m) {
        const auto now = Clock::now();
        ++corrected_count;
        const double k_real = (m->header.stamp - start).toSec() / period;
        const long long k = std::llround(k_real);
        if (k < 0) {  // priming samples are stamped before start
          ++priming_seen;
          return;
        }
        if (static_cast<std::size_t>(k) >= total || std::abs(k_real - static_cast<double>(k)) > 1e-3) {
          ++foreign;
          return;
        }
        arrived[static_cast<std::size_t>(k)].store(std::chrono::duration_cast<std::chrono::nanoseconds>(now - t_ref).count());
      },
      ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  ros::Publisher test = nh.advertise<sensor_msgs::MagneticField>(test_topic, 1000);
  ros::Publisher cal = nh.advertise<magnetometer_insitu_calibration::MagnetometerCalibration>(calibration_topic, 1, true);
  ros::AsyncSpinner spinner(1);  // the corrected samples are taken on their own thread
  spinner.start();

  // A valid accepted calibration: small scale/orientation differences, tiny covariance.
  magnetometer_insitu_calibration::MagnetometerCalibration c;
  c.header.stamp = ros::Time::now();
  c.header.frame_id = "probe_reference";
  c.test_name = "probe";
  c.reference_frame_id = "probe_reference";
  c.test_frame_id = frame;
  c.window_start = start - ros::Duration(86400.0);
  c.window_end = start - ros::Duration(1.0);
  c.sample_period = 1.0;
  c.samples = 86400;
  c.band_low_hz = 0.0002;
  c.band_high_hz = 0.01;
  c.harmonic_first = 18;
  c.harmonic_last = 864;
  c.gamma = 1.0;
  c.trend_column = true;
  c.method = "robust";
  c.band_used_low_hz = c.band_low_hz;
  c.band_used_high_hz = c.band_high_hz;
  c.delay_s = 0.0;
  c.delay_ci95_s = 0.001;
  const double n[9] = {0.9996, 0.0002, -0.0009, -0.0002, 1.0004, 0.0052, 0.0009, -0.0053, 1.0004};
  for (int k = 0; k < 9; ++k) c.matrix[k] = n[k];
  for (int k = 0; k < 9; ++k) c.matrix_covariance[k * 9 + k] = 1e-10;
  c.offset_nT = {1.5, -2.0, 0.5};
  c.offset_ci95_nT = {0.1, 0.1, 0.1};
  c.scale_ratio = {0.9996, 1.0004, 1.0004};
  c.condition_number = 3.0;
  c.coherence = {0.999, 0.999, 0.998};
  c.quality = magnetometer_insitu_calibration::MagnetometerCalibration::QUALITY_OK;
  c.quality_text = "ok";
  c.accepted = true;
  cal.publish(c);

  sensor_msgs::MagneticField msg;
  msg.header.frame_id = frame;
  msg.magnetic_field_covariance[0] = msg.magnetic_field_covariance[4] = msg.magnetic_field_covariance[8] = 4e-22;
  auto fill = [&](std::size_t k, ros::Time stamp) {
    msg.header.stamp = stamp;
    const double t = static_cast<double>(k) * period;
    msg.magnetic_field.x = 2.1e-5 + 2e-9 * std::sin(0.01 * t);
    msg.magnetic_field.y = 1.5e-6 + 1e-9 * std::cos(0.013 * t);
    msg.magnetic_field.z = 4.4e-5 - 1e-9 * std::sin(0.007 * t);
  };

  // Connections, then priming samples (stamped before start) until one comes back corrected.
  const auto deadline = Clock::now() + std::chrono::seconds(60);
  while (ros::ok() && Clock::now() < deadline &&
         (test.getNumSubscribers() == 0 || sub.getNumPublishers() == 0 || cal.getNumSubscribers() == 0)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  for (int p = 0; ros::ok() && priming_seen.load() == 0 && Clock::now() < deadline; ++p) {
    fill(0, start - ros::Duration(5.0) + ros::Duration(0.001 * p));
    test.publish(msg);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  if (priming_seen.load() == 0) {
    std::fprintf(stderr, "bench_correction_probe: no corrected sample within 60 s (is correction_node on %s -> %s?)\n",
                 test_topic.c_str(), corrected_topic.c_str());
    return 1;
  }

  std::size_t late_ticks = 0;
  const Clock::time_point t0 = Clock::now() + std::chrono::milliseconds(200);
  std::size_t k = 0;
  for (; k < total && ros::ok(); ++k) {
    const auto due = t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(static_cast<double>(k) * period));
    std::this_thread::sleep_until(due);
    fill(k, start + ros::Duration(static_cast<double>(k) * period));
    const auto now = Clock::now();
    if (now - due > std::chrono::milliseconds(10) && k >= warm_ticks) ++late_ticks;
    published[k] = now;
    test.publish(msg);
  }
  std::this_thread::sleep_for(std::chrono::seconds(2));  // stragglers
  spinner.stop();

  std::vector<double> lat;
  std::size_t received = 0;
  FILE* csv = csv_path.empty() ? nullptr : std::fopen(csv_path.c_str(), "w");
  if (csv) std::fprintf(csv, "k,stamp,latency_ms\n");
  for (std::size_t i = warm_ticks; i < k; ++i) {
    const std::int64_t a = arrived[i].load();
    double ms = std::numeric_limits<double>::quiet_NaN();
    if (a >= 0) {
      ms = 1e-6 * static_cast<double>(a - std::chrono::duration_cast<std::chrono::nanoseconds>(published[i] - t_ref).count());
      lat.push_back(ms);
      ++received;
    }
    if (csv) std::fprintf(csv, "%zu,%.3f,%.4f\n", i, (start + ros::Duration(static_cast<double>(i) * period)).toSec(), ms);
  }
  if (csv) std::fclose(csv);
  double mean = 0;
  for (double v : lat) mean += v;
  mean = lat.empty() ? std::numeric_limits<double>::quiet_NaN() : mean / static_cast<double>(lat.size());
  const std::size_t timed = k > warm_ticks ? k - warm_ticks : 0;
  std::printf("latency_ms samples=%zu received=%zu lost=%zu median=%.3f p90=%.3f p99=%.3f max=%.3f mean=%.3f late_ticks=%zu foreign=%zu\n",
              timed, received, timed - received, quantile(lat, 0.5), quantile(lat, 0.9), quantile(lat, 0.99),
              lat.empty() ? std::numeric_limits<double>::quiet_NaN() : *std::max_element(lat.begin(), lat.end()), mean,
              late_ticks, foreign.load());
  std::fflush(stdout);
  return received == timed ? 0 : 1;
}
