// records_to_bag: a reference and a test record (IAGA-2002, CSV, LemiBin, LEMI-025 compact
// flash, raw LEMI-025 byte stream, MagPy CDF, ImagCDF; format recognised from the content; several
// files per instrument joined in time order) into one rosbag of
// sensor_msgs/MagneticField (tesla, stamps from the records, frame ids from the options) and,
// for the LEMI formats and CDF temperature channels, sensor_msgs/Temperature. No ROS master needed.
//
//   records_to_bag --reference REF --test TEST --output pair.bag
//                  [--reference-topic /reference/magnetic_field] [--test-topic /test/magnetic_field]
//                  [--reference-frame reference] [--test-frame test] [--compression none|bz2|lz4]
//
// A damaged text line (IAGA-2002, CSV) refuses the file, naming file and line, as in
// calibrate_records and export_corrected (one rule for bad input); with --skip-damaged it is
// reported and skipped and the good lines around it are kept. A damaged binary record (a LEMI
// packet or block with a bad checksum or time) is reported with its byte offset and skipped, as
// every reader of those formats does. Exit status 0 when the bag was written (the number of
// skipped records is printed), 1 when it could not be.
#include "archive_records.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "bag_records.hpp"  // src/program_support
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include "command_line.hpp"  // parse_command_line: exit 1 on a usage error (src/program_support)

#include <CLI/CLI.hpp>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <thread>
#include <unistd.h>

namespace mic = magnetometer_insitu_calibration;

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

/// Progress on stderr: rewritten in place on a terminal, one line at most every few seconds
/// otherwise; nothing for short jobs (the first report waits `delay_s`).
class Progress {
 public:
  Progress(bool enabled, double delay_s) : enabled_(enabled), delay_s_(delay_s), tty_(isatty(2) != 0) {}
  void start(const std::string& what) {
    std::lock_guard<std::mutex> lock(mutex_);
    what_ = what;
    started_ = last_ = Clock::now();
    shown_ = false;
  }
  void update(double fraction, const std::string& detail = "") {
    if (!enabled_) return;
    std::lock_guard<std::mutex> lock(mutex_);
    const double since_start = seconds_since(started_), since_last = seconds_since(last_);
    if (since_start < delay_s_ || (since_last < (tty_ ? 0.2 : 5.0) && shown_)) return;
    last_ = Clock::now();
    shown_ = true;
    char line[256];
    std::snprintf(line, sizeof line, "records_to_bag: %s %5.1f %%%s%s", what_.c_str(), 100.0 * fraction,
                  detail.empty() ? "" : " ", detail.c_str());
    std::cerr << (tty_ ? "\r" : "") << line << (tty_ ? "" : "\n") << std::flush;
  }
  void finish() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (enabled_ && shown_ && tty_) std::cerr << "\n";
    shown_ = false;
  }

 private:
  bool enabled_;
  double delay_s_;
  bool tty_;
  std::string what_;
  Clock::time_point started_, last_;
  bool shown_ = false;
  std::mutex mutex_;
};

/// Progress of a reader that gives none: a thread looks every 0.25 s for the file among this
/// process's open descriptors and reports its position (/proc/self/fdinfo) against its size.
class ReadWatcher {
 public:
  ReadWatcher(const std::string& path, Progress& progress) : progress_(progress) {
    std::error_code error;
    target_ = std::filesystem::canonical(path, error);
    size_ = std::filesystem::file_size(path, error);
    if (error || size_ == 0) return;
    thread_ = std::thread([this] { run(); });
  }
  ~ReadWatcher() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

 private:
  void run() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!cv_.wait_for(lock, std::chrono::milliseconds(250), [this] { return stop_; })) {
      std::error_code error;
      for (const auto& entry : std::filesystem::directory_iterator("/proc/self/fd", error)) {
        std::error_code link_error;
        if (std::filesystem::read_symlink(entry.path(), link_error) != target_) continue;
        std::ifstream info("/proc/self/fdinfo/" + entry.path().filename().string());
        std::string key;
        unsigned long long pos = 0;
        while (info >> key) {
          if (key == "pos:" && info >> pos) {
            progress_.update(static_cast<double>(pos) / static_cast<double>(size_));
            break;
          }
        }
        break;
      }
    }
  }

  Progress& progress_;
  std::filesystem::path target_;
  std::uintmax_t size_ = 0;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false;
};


std::string time_range(const mic::VectorRecord& r) {
  if (r.empty()) return "no samples";
  return mic::format_iso8601(r.time_s.front(), 3) + " .. " + mic::format_iso8601(r.time_s.back(), 3);
}

/// Without --skip-damaged, a text file with damaged lines is refused with the first of them.
void refuse_damaged_text(const std::string& path, const mic::ArchiveRecord& r) {
  const bool text = r.format == mic::RecordFormat::kIaga2002 || r.format == mic::RecordFormat::kCsv;
  if (!text || r.skipped == 0 || r.problems.empty()) return;
  std::string first = r.problems.front();
  const std::string skipped = " (line skipped)";
  if (first.size() > skipped.size() && first.compare(first.size() - skipped.size(), skipped.size(), skipped) == 0) {
    first.resize(first.size() - skipped.size());
  }
  throw mic::InputError(path, std::to_string(r.skipped) + " damaged line(s), the first " + first +
                                  "; refused (--skip-damaged converts the other lines)");
}

mic::ArchiveRecord read_one(const std::string& role, const std::string& path, const mic::ArchiveReadOptions& base,
                            Progress& progress, std::size_t max_problems, bool skip_damaged) {
  mic::ArchiveReadOptions options = base;
  options.progress = [&progress](double fraction) { progress.update(fraction); };
  const Clock::time_point start = Clock::now();
  progress.start("reading " + path);
  mic::ArchiveRecord r;
  {
    ReadWatcher watcher(path, progress);
    r = mic::read_archive_record(path, options);
  }
  progress.finish();
  if (!skip_damaged) refuse_damaged_text(path, r);
  for (std::size_t i = 0; i < r.problems.size() && i < max_problems; ++i) {
    std::cerr << "records_to_bag: warning: " << r.problems[i] << "\n";
  }
  if (r.problems.size() > max_problems) {
    std::cerr << "records_to_bag: ... and " << (r.problems.size() - max_problems) << " more problems in " << path
              << "\n";
  }
  char seconds[32];
  std::snprintf(seconds, sizeof seconds, "%.2f s", seconds_since(start));
  std::cout << role << ": " << path << " (" << mic::record_format_name(r.format) << "): " << r.record.size()
            << " samples, " << time_range(r.record) << ", " << r.skipped << " records skipped"
            << (r.temperatures.empty() ? std::string() : ", " + std::to_string(r.temperatures.size()) + " temperatures")
            << " (" << seconds << ")\n";
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Reference and test magnetometer records -> one rosbag of sensor_msgs/MagneticField (tesla)."};
  std::vector<std::string> reference_paths, test_paths, remote_paths;  // several files: joined in time order
  std::string output;
  std::string reference_topic = "/reference/magnetic_field", test_topic = "/test/magnetic_field",
              remote_topic = "/remote/magnetic_field";
  std::string reference_frame = "reference", test_frame = "test", compression = "none", checksum = "none";
  bool no_temperatures = false, variation = false, quiet = false, skip_damaged = false;
  double time_shift_s = mic::kLemi025TimeShift_s;
  std::size_t max_problems = 20;
  double progress_delay_s = 1.0;
  app.add_option("--reference", reference_paths,
                 "reference record: IAGA-2002, CSV (.gz allowed), LemiBin, LEMI compact flash, LEMI-025 byte stream, "
                 "MagPy CDF, ImagCDF; several files (daily files) are joined in time order")
      ->required();
  app.add_option("--test", test_paths, "test record, same formats, one or several files")->required();
  app.add_option("--remote", remote_paths, "a remote observatory's record (same formats), on --remote-topic, frame 'remote'");
  app.add_option("--remote-topic", remote_topic, "sensor_msgs/MagneticField topic of the remote")->capture_default_str();
  app.add_option("-o,--output", output, "bag to write (replaced if it exists)")->required();
  app.add_option("--reference-topic", reference_topic, "sensor_msgs/MagneticField topic of the reference")
      ->capture_default_str();
  app.add_option("--test-topic", test_topic, "sensor_msgs/MagneticField topic of the test")->capture_default_str();
  app.add_option("--reference-frame", reference_frame, "header.frame_id of the reference")->capture_default_str();
  app.add_option("--test-frame", test_frame, "header.frame_id of the test")->capture_default_str();
  app.add_option("--compression", compression, "bag chunk compression: none, bz2, lz4")->capture_default_str();
  app.add_flag("--no-temperatures", no_temperatures,
               "do not write the LEMI or CDF temperatures (<topic namespace>/temperature/sensor, "
               ".../temperature/electronics, as lemi025_driver publishes them)");
  app.add_flag("--lemi-variation", variation, "LEMI formats: variation relative to the bias field, not the full field");
  app.add_option("--lemi-checksum", checksum, "LEMI packets: checksum none, sum8, xor8")->capture_default_str();
  app.add_option("--lemi-time-shift", time_shift_s, "LEMI formats: seconds added to the GPS time of the readings")
      ->capture_default_str();
  app.add_option("--max-problems", max_problems, "problems printed per file (all are counted)")->capture_default_str();
  app.add_flag("--skip-damaged", skip_damaged,
               "IAGA-2002 and CSV: skip a damaged line (reported with its number) instead of refusing the file");
  app.add_flag("-q,--quiet", quiet, "no progress display");
  app.add_option("--progress-delay", progress_delay_s, "seconds into a step before its progress is shown")
      ->capture_default_str();
  if (const auto status = mic::parse_command_line(app, argc, argv)) return *status;

  try {
    const Clock::time_point start = Clock::now();
    mic::ArchiveReadOptions options;
    options.lemi.field = variation ? mic::LemiFieldMode::kVariation : mic::LemiFieldMode::kFullField;
    options.lemi.time_shift_s = time_shift_s;
    const auto mode = mic::parse_checksum_mode(checksum);
    if (!mode) throw mic::InputError("--lemi-checksum", "expected none, sum8 or xor8, got '" + checksum + "'");
    options.lemi.checksum = *mode;
    const mic::BagCompression bag_compression = mic::parse_bag_compression(compression, "--compression");
    if (mic::bag_topic_name(reference_topic) == mic::bag_topic_name(test_topic)) {
      throw mic::InputError("--test-topic", "is the same topic as --reference-topic");
    }

    Progress progress(!quiet, progress_delay_s);
    auto read_all = [&](const std::string& role, const std::vector<std::string>& paths) {
      std::vector<mic::ArchiveRecord> parts;
      for (const std::string& path : paths) parts.push_back(read_one(role, path, options, progress, max_problems, skip_damaged));
      if (parts.size() == 1) return std::move(parts.front());
      std::size_t printed = 0;  // the parts' own problems, printed by read_one; then the joining's
      for (const mic::ArchiveRecord& part : parts) printed += part.problems.size();
      mic::ArchiveRecord joined = mic::join_archive_records(std::move(parts));
      for (std::size_t i = printed; i < joined.problems.size(); ++i) {
        std::cerr << "records_to_bag: warning: " << joined.problems[i] << "\n";
      }
      std::cout << role << ": " << paths.size() << " files joined: " << joined.record.size() << " samples, "
                << time_range(joined.record) << "\n";
      return joined;
    };
    const mic::ArchiveRecord reference = read_all("reference", reference_paths);
    const mic::ArchiveRecord test = read_all("test", test_paths);

    const mic::ArchiveRecord remote = remote_paths.empty() ? mic::ArchiveRecord{} : read_all("remote", remote_paths);
    std::vector<mic::BagFieldStream> fields = {{reference_topic, reference_frame, &reference.record},
                                               {test_topic, test_frame, &test.record}};
    if (!remote_paths.empty()) fields.push_back({remote_topic, "remote", &remote.record});
    std::vector<mic::BagTemperatureStream> temperatures;
    if (!no_temperatures) {
      const std::pair<const mic::ArchiveRecord*, const mic::BagFieldStream*> inputs[] = {{&reference, &fields[0]},
                                                                                          {&test, &fields[1]}};
      for (const auto& [record, field] : inputs) {
        if (record->temperatures.empty()) continue;
        temperatures.push_back({mic::bag_sibling_topic(field->topic, "temperature/sensor"), field->frame_id,
                                record->temperatures.time_s, record->temperatures.sensor_C});
        temperatures.push_back({mic::bag_sibling_topic(field->topic, "temperature/electronics"), field->frame_id,
                                record->temperatures.time_s, record->temperatures.electronics_C});
      }
    }
    const Clock::time_point write_start = Clock::now();
    progress.start("writing " + output);
    const mic::BagWriteSummary summary = mic::write_records_bag(
        output, fields, temperatures, bag_compression, [&progress](std::size_t done, std::size_t total) {
          progress.update(total > 0 ? static_cast<double>(done) / static_cast<double>(total) : 1.0,
                          "(" + std::to_string(done) + "/" + std::to_string(total) + " messages)");
        });
    progress.finish();
    char timing[96];
    std::snprintf(timing, sizeof timing, "%.2f s writing, %.2f s in all", seconds_since(write_start),
                  seconds_since(start));
    std::cout << "wrote " << output << ": " << summary.messages << " messages (" << timing << ")\n";
    for (const auto& [topic, count] : summary.per_topic) std::cout << "  " << topic << ": " << count << "\n";
    std::cout << "skipped records: " << reference.skipped << " in the reference, " << test.skipped << " in the test\n";
  } catch (const mic::InputError& e) {
    std::cerr << "records_to_bag: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "records_to_bag: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
