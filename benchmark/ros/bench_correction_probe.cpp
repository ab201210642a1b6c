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


/// The command line: rate (Hz), timed duration and warm-up (s), topics, frame, outputs.
struct Options {
  double rate = 10.0, duration = 120.0, warmup = 5.0;
  std::string test_topic = "/probe/test", corrected_topic = "/probe/corrected",
              calibration_topic = "/probe/calibration", frame = "probe_test", csv_path, nodelet_name;
};

/// Reads "--option value" pairs; false (after a message on stderr) for an unknown option or an
/// impossible value.
bool parse_options(int argc, char** argv, Options& o) {
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string option = argv[i];
    const char* v = argv[i + 1];
    if (option == "--rate") o.rate = std::atof(v);
    else if (option == "--duration") o.duration = std::atof(v);
    else if (option == "--warmup") o.warmup = std::atof(v);
    else if (option == "--test-topic") o.test_topic = v;
    else if (option == "--corrected-topic") o.corrected_topic = v;
    else if (option == "--calibration-topic") o.calibration_topic = v;
    else if (option == "--frame") o.frame = v;
    else if (option == "--csv") o.csv_path = v;
    else if (option == "--load-nodelet") o.nodelet_name = v;
    else {
      std::fprintf(stderr, "bench_correction_probe: unknown option %s\n", option.c_str());
      return false;
    }
  }
  if (!(o.rate > 0) || !(o.duration > 0) || !(o.warmup >= 0)) {
    std::fprintf(stderr, "bench_correction_probe: impossible option\n");
    return false;
  }
  return true;
}

/// The probe's samples: sample k is stamped start + k period (s); published[k] is the steady
/// time just before its publish(), arrived[k] the arrival of its corrected sample in ns after
/// t_ref (-1: none). Priming samples (stamped before start) and foreign stamps are counted.
struct Samples {
  Samples(ros::Time start_, double period_, std::size_t total_)
      : start(start_), period(period_), total(total_), published(total_),
        arrived(new std::atomic<std::int64_t>[total_]) {
    for (std::size_t k = 0; k < total; ++k) arrived[k].store(-1);
    t_ref = Clock::now();
  }
  ros::Time stamp(std::size_t k) const { return start + ros::Duration(static_cast<double>(k) * period); }

  /// The corrected-topic callback (the spinner's thread).
  void on_corrected(const sensor_msgs::MagneticField::ConstPtr& m) {
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
  }

  const ros::Time start;
  const double period;
  const std::size_t total;
  std::vector<Clock::time_point> published;
  std::unique_ptr<std::atomic<std::int64_t>[]> arrived;
  std::atomic<std::size_t> corrected_count{0}, foreign{0}, priming_seen{0};
  Clock::time_point t_ref;
};

/// A valid accepted calibration of a one-day window ending before the first (priming) sample,
/// stamped start - 5 s: correction_node refuses a calibration of later data than its stream's
/// first sample. Small scale/orientation differences, offsets of a few nT, tiny covariance.
magnetometer_insitu_calibration::MagnetometerCalibration probe_calibration(const std::string& frame, ros::Time start) {
  magnetometer_insitu_calibration::MagnetometerCalibration c;
  c.header.stamp = ros::Time::now();
  c.header.frame_id = "probe_reference";
  c.test_name = "probe";
  c.reference_frame_id = "probe_reference";
  c.test_frame_id = frame;
  c.window_start = start - ros::Duration(86400.0);
  c.window_end = start - ros::Duration(10.0);
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
  return c;
}

/// The field of sample k (tesla: about 21, 1.5, 44 uT with nT-sized variations), stamped `stamp`.
void fill_sample(sensor_msgs::MagneticField& msg, std::size_t k, double period, ros::Time stamp) {
  msg.header.stamp = stamp;
  const double t = static_cast<double>(k) * period;
  msg.magnetic_field.x = 2.1e-5 + 2e-9 * std::sin(0.01 * t);
  msg.magnetic_field.y = 1.5e-6 + 1e-9 * std::cos(0.013 * t);
  msg.magnetic_field.z = 4.4e-5 - 1e-9 * std::sin(0.007 * t);
}

/// Waits (60 s at most) for the connections, then publishes priming samples (stamped before
/// start) every 100 ms until one comes back corrected; false when none did.
bool wait_until_correcting(const ros::Publisher& test, const ros::Subscriber& sub, const ros::Publisher& cal,
                           sensor_msgs::MagneticField& msg, const Samples& samples) {
  const auto deadline = Clock::now() + std::chrono::seconds(60);
  while (ros::ok() && Clock::now() < deadline &&
         (test.getNumSubscribers() == 0 || sub.getNumPublishers() == 0 || cal.getNumSubscribers() == 0)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  for (int p = 0; ros::ok() && samples.priming_seen.load() == 0 && Clock::now() < deadline; ++p) {
    fill_sample(msg, 0, samples.period, samples.start - ros::Duration(5.0) + ros::Duration(0.001 * p));
    test.publish(msg);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return samples.priming_seen.load() != 0;
}

/// Publishes the samples on their schedule (one per period, steady clock, from 200 ms on);
/// counts the timed ones published more than 10 ms late. Returns how many were published.
std::size_t publish_samples(const ros::Publisher& test, sensor_msgs::MagneticField& msg, Samples& samples,
                            std::size_t warm_ticks, std::size_t& late_ticks) {
  const Clock::time_point t0 = Clock::now() + std::chrono::milliseconds(200);
  std::size_t k = 0;
  for (; k < samples.total && ros::ok(); ++k) {
    const auto due = t0 + std::chrono::duration_cast<Clock::duration>(
                              std::chrono::duration<double>(static_cast<double>(k) * samples.period));
    std::this_thread::sleep_until(due);
    fill_sample(msg, k, samples.period, samples.stamp(k));
    const auto now = Clock::now();
    if (now - due > std::chrono::milliseconds(10) && k >= warm_ticks) ++late_ticks;
    samples.published[k] = now;
    test.publish(msg);
  }
  return k;
}

/// The latencies (ms) of the timed samples warm_ticks .. published - 1: the CSV (when asked for)
/// and the summary line on stdout. Returns whether every timed sample came back.
bool report(const Samples& samples, std::size_t warm_ticks, std::size_t published, std::size_t late_ticks,
            const std::string& csv_path) {
  std::vector<double> lat;
  std::size_t received = 0;
  FILE* csv = csv_path.empty() ? nullptr : std::fopen(csv_path.c_str(), "w");
  if (csv) std::fprintf(csv, "k,stamp,latency_ms\n");
  for (std::size_t i = warm_ticks; i < published; ++i) {
    const std::int64_t a = samples.arrived[i].load();
    double ms = std::numeric_limits<double>::quiet_NaN();
    if (a >= 0) {
      ms = 1e-6 * static_cast<double>(a - std::chrono::duration_cast<std::chrono::nanoseconds>(
                                              samples.published[i] - samples.t_ref).count());
      lat.push_back(ms);
      ++received;
    }
    if (csv) std::fprintf(csv, "%zu,%.3f,%.4f\n", i, samples.stamp(i).toSec(), ms);
  }
  if (csv) std::fclose(csv);
  double mean = 0;
  for (double v : lat) mean += v;
  mean = lat.empty() ? std::numeric_limits<double>::quiet_NaN() : mean / static_cast<double>(lat.size());
  const std::size_t timed = published > warm_ticks ? published - warm_ticks : 0;
  std::printf("latency_ms samples=%zu received=%zu lost=%zu median=%.3f p90=%.3f p99=%.3f max=%.3f mean=%.3f late_ticks=%zu foreign=%zu\n",
              timed, received, timed - received, quantile(lat, 0.5), quantile(lat, 0.9), quantile(lat, 0.99),
              lat.empty() ? std::numeric_limits<double>::quiet_NaN() : *std::max_element(lat.begin(), lat.end()), mean,
              late_ticks, samples.foreign.load());
  std::fflush(stdout);
  return received == timed;
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "bench_correction_probe", ros::init_options::AnonymousName);
  Options o;
  if (!parse_options(argc, argv, o)) return 2;
  const double period = 1.0 / o.rate;
  const auto warm_ticks = static_cast<std::size_t>(std::llround(o.warmup * o.rate));
  const auto timed_ticks = static_cast<std::size_t>(std::llround(o.duration * o.rate));
  // Index k of a sample: stamp = start + k period. The start is a whole second of wall time.
  Samples samples(ros::Time(std::floor(ros::WallTime::now().toSec()) + 10.0), period, warm_ticks + timed_ticks);

  ros::NodeHandle nh;
  // In-process correction: this process is its nodelet manager (no ROS services: a plain loader).
  std::unique_ptr<nodelet::Loader> manager;
  if (!o.nodelet_name.empty()) {
    manager = std::make_unique<nodelet::Loader>(false);
    if (!manager->load(o.nodelet_name, "magnetometer_insitu_calibration/correction_node", nodelet::M_string(),
                       nodelet::V_string())) {
      std::fprintf(stderr, "bench_correction_probe: cannot load the correction_node nodelet as %s\n", o.nodelet_name.c_str());
      return 1;
    }
  }
  ros::Subscriber sub = nh.subscribe<sensor_msgs::MagneticField>(
      o.corrected_topic, 100000, [&samples](const sensor_msgs::MagneticField::ConstPtr& m) { samples.on_corrected(m); },
      ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  ros::Publisher test = nh.advertise<sensor_msgs::MagneticField>(o.test_topic, 1000);
  ros::Publisher cal = nh.advertise<magnetometer_insitu_calibration::MagnetometerCalibration>(o.calibration_topic, 1, true);
  ros::AsyncSpinner spinner(1);  // the corrected samples are taken on their own thread
  spinner.start();
  cal.publish(probe_calibration(o.frame, samples.start));

  sensor_msgs::MagneticField msg;  // covariance (T^2) as a LEMI-025 driver sets it
  msg.header.frame_id = o.frame;
  msg.magnetic_field_covariance[0] = msg.magnetic_field_covariance[4] = msg.magnetic_field_covariance[8] = 4e-22;
  if (!wait_until_correcting(test, sub, cal, msg, samples)) {
    std::fprintf(stderr, "bench_correction_probe: no corrected sample within 60 s (is correction_node on %s -> %s?)\n",
                 o.test_topic.c_str(), o.corrected_topic.c_str());
    return 1;
  }
  std::size_t late_ticks = 0;
  const std::size_t published = publish_samples(test, msg, samples, warm_ticks, late_ticks);
  std::this_thread::sleep_for(std::chrono::seconds(2));  // stragglers
  spinner.stop();
  return report(samples, warm_ticks, published, late_ticks, o.csv_path) ? 0 : 1;
}
