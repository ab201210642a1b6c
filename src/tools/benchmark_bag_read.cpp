// benchmark_bag_read: how long calibrate_records --bag spends reading a bag, against a bare
// rosbag::View pass over the same bag, and against the calibration itself.
//
// Data: one day of two 10 Hz instruments (simulate_pair, 864000 samples each) written by
// write_records_bag as records_to_bag writes them (uncompressed unless --compression), i.e.
// 1 728 000 sensor_msgs/MagneticField messages. Timed, each --repeat times alternately, after
// one warm-up pass (the bag is then in the page cache: both passes read from memory):
//   bare   rosbag::View over the two topics, instantiate<sensor_msgs::MagneticField>() per
//          message, stamp and field summed (the least a reader must do);
//   read   read_bag_records (what calibrate_records --bag does before the calibration);
//   calib  calibrate_records() on the two records, --intervals 4 (pre-processing with the
//          Gaussian FIR decimation to 1 Hz, four 6-hour intervals and the day).
// Prints the median and the fastest of each, and read / bare.
//
//   benchmark_bag_read [--bag existing.bag] [--keep path.bag] [--repeat 5] [--compression none]
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "bag_records.hpp"  // src/program_support
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include "command_line.hpp"  // parse_command_line: exit 1 on a usage error (src/program_support)

#include <CLI/CLI.hpp>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/MagneticField.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <unistd.h>
#include <iostream>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

using Clock = std::chrono::steady_clock;

const char* kReference = "/reference/magnetic_field";
const char* kTest = "/test/magnetic_field";

double bare_pass(const std::string& path, std::size_t& messages) {
  rosbag::Bag bag(path, rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery(std::vector<std::string>{kReference, kTest}));
  double sum = 0.0;
  messages = 0;
  for (const rosbag::MessageInstance& m : view) {
    const sensor_msgs::MagneticField::ConstPtr msg = m.instantiate<sensor_msgs::MagneticField>();
    if (!msg) continue;
    sum += msg->header.stamp.toSec() + msg->magnetic_field.x + msg->magnetic_field.y + msg->magnetic_field.z;
    ++messages;
  }
  return sum;
}

struct Stats {
  std::vector<double> seconds;
  double median() const {
    std::vector<double> s = seconds;
    std::sort(s.begin(), s.end());
    return s.empty() ? 0.0 : s[s.size() / 2];
  }
  double best() const { return seconds.empty() ? 0.0 : *std::min_element(seconds.begin(), seconds.end()); }
};

template <typename F>
double timed(F&& f) {
  const auto start = Clock::now();
  f();
  return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Bag reading of calibrate_records --bag against a bare rosbag::View pass (one day, two 10 Hz instruments)."};
  std::string bag_path, keep, compression = "none";
  int repeat = 5;
  app.add_option("--bag", bag_path, "use this bag (topics /reference/magnetic_field and /test/magnetic_field)");
  app.add_option("--keep", keep, "write the simulated bag here and keep it");
  app.add_option("--repeat", repeat, "timed passes of each kind")->capture_default_str();
  app.add_option("--compression", compression, "none, bz2 or lz4 (simulated bag)")->capture_default_str();
  if (const auto status = mic::parse_command_line(app, argc, argv)) return *status;

  std::filesystem::path temp_dir;
  if (bag_path.empty()) {
    if (keep.empty()) {
      temp_dir = std::filesystem::temp_directory_path() / ("mic_bench_bag_" + std::to_string(::getpid()));
      std::filesystem::create_directories(temp_dir);
      bag_path = (temp_dir / "day_10hz.bag").string();
    } else {
      bag_path = keep;
    }
    mic::SimulationSettings s;
    s.sample_period_s = 0.1;
    s.duration_s = 86400.0;
    s.keep_clean_field = false;
    double simulate_s = 0.0, write_s = 0.0;
    mic::SimulatedPair pair;
    simulate_s = timed([&] { pair = mic::simulate_pair(s); });
    mic::BagWriteSummary summary;
    write_s = timed([&] {
      summary = mic::write_records_bag(bag_path, {{kReference, "reference", &pair.reference}, {kTest, "test", &pair.test}},
                                       {}, mic::parse_bag_compression(compression, "--compression"));
    });
    std::printf("simulated 2 x %zu samples at 10 Hz in %.2f s; wrote %zu messages to %s (%.0f MB, %s) in %.2f s\n",
                pair.reference.size(), simulate_s, summary.messages, bag_path.c_str(),
                static_cast<double>(std::filesystem::file_size(bag_path)) / 1e6, compression.c_str(), write_s);
  }

  std::size_t messages = 0;
  std::vector<mic::VectorRecord> records;
  bare_pass(bag_path, messages);  // warm-up: the bag into the page cache
  Stats bare, read, calib;
  volatile double sink = 0.0;
  for (int i = 0; i < repeat; ++i) {
    bare.seconds.push_back(timed([&] { sink = sink + bare_pass(bag_path, messages); }));
    read.seconds.push_back(timed([&] { records = mic::read_bag_records(bag_path, {kReference, kTest}); }));
  }
  mic::CalibrationSettings settings;
  settings.windows.intervals = 4;
  for (int i = 0; i < std::max(1, repeat / 2); ++i) {
    calib.seconds.push_back(timed([&] {
      const mic::PairCalibration c = mic::calibrate_records(records[0], records[1], settings);
      sink = sink + c.windows.back().estimate.n(0, 0);
    }));
  }
  std::printf("%zu messages, %zu + %zu samples read\n", messages, records[0].size(), records[1].size());
  std::printf("%-44s median %7.3f s  best %7.3f s\n", "bare rosbag::View pass (instantiate)", bare.median(), bare.best());
  std::printf("%-44s median %7.3f s  best %7.3f s\n", "read_bag_records (calibrate_records --bag)", read.median(),
              read.best());
  std::printf("%-44s median %7.3f s  best %7.3f s\n", "calibrate_records() on them, --intervals 4", calib.median(),
              calib.best());
  Stats ratio;  // pass by pass (each read right after its bare pass): less sensitive to other load
  for (std::size_t i = 0; i < read.seconds.size(); ++i) ratio.seconds.push_back(read.seconds[i] / bare.seconds[i]);
  std::printf("read / bare: %.3f (medians), %.3f (best times), %.3f (median of the %zu pass-by-pass ratios)\n",
              read.median() / bare.median(), read.best() / bare.best(), ratio.median(), ratio.seconds.size());
  if (!temp_dir.empty()) std::filesystem::remove_all(temp_dir);
  return 0;
}
