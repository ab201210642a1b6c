// record_file_follower with a real master (record_file_follower.test, _nodelet.test): pieces of
// the real WIC day (data/wic20250514_lemi036.sec.gz) written into a temporary folder as a remote
// observatory's files arrive, the node started and stopped by the test itself.
//   RecordFileFollower.FollowsFilesThroughFaultsAndARestart  a day written line by line (its last
//       line cut: not published until complete), rewritten with more lines, files of another
//       station and sample period beside it (refused, named in a warning and the diagnostics), the
//       stamps stepping back (refused, counted) and jumping ahead (a gap), the node restarted
//       mid-day: every sample published is the day's (stamp, tesla value, frame), in order, once;
//   RecordFileFollower.ReplaysAnArchiveOnce  three hours, as IAGA-2002 gzip, ImagCDF and IAGA-2002
//       without a last line end, replayed once as fast as possible (~follow false, ~rate 0), and
//       at ~rate 5000 (no faster than the stamps allow);
//   RecordFileFollower.ImpossibleParametersAreFatal  the node exits 1 naming the parameter;
//   RecordFileFollower.FollowsAsANodelet  the nodelet of the .test file follows its folder.
// Waits are for conditions (kPatience_s at most), never for counts by deadlines.
#include "child_process.hpp"
#include "formats/wic_day_pieces.hpp"
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/formats/imagcdf_writer.hpp"
#include "magnetometer_insitu_calibration/formats/record_follower.hpp"
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"
#include "wait_condition.hpp"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/MagneticField.h>

#include <sys/stat.h>

#include <cstdio>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

constexpr double kPatience_s = 90.0;

struct Received {
  double stamp_s = 0.0;
  double x_T = 0.0, y_T = 0.0, z_T = 0.0;
  std::string frame_id;
  bool covariance_zero = true;
  double arrival_wall_s = 0.0;
};

/// Records the follower's topic, /diagnostics and /rosout.
class Listener {
 public:
  explicit Listener(const std::string& topic) : spinner_(1) {
    field_ = nh_.subscribe<sensor_msgs::MagneticField>(topic, 200000, [this](const sensor_msgs::MagneticField::ConstPtr& m) {
      Received r{m->header.stamp.toSec(), m->magnetic_field.x, m->magnetic_field.y, m->magnetic_field.z, m->header.frame_id};
      for (double c : m->magnetic_field_covariance) r.covariance_zero = r.covariance_zero && c == 0.0;
      r.arrival_wall_s = ros::WallTime::now().toSec();
      std::lock_guard<std::mutex> lock(mutex_);
      received_.push_back(r);
    });
    diagnostics_ = nh_.subscribe<diagnostic_msgs::DiagnosticArray>(
        "/diagnostics", 1000, [this](const diagnostic_msgs::DiagnosticArray::ConstPtr& a) {
          std::lock_guard<std::mutex> lock(mutex_);
          for (const auto& s : a->status) {
            auto& d = diagnostics_by_name_[s.name];
            d.clear();
            d["level"] = std::to_string(s.level);
            d["message"] = s.message;
            for (const auto& kv : s.values) d[kv.key] = kv.value;
          }
        });
    rosout_ = nh_.subscribe<rosgraph_msgs::Log>("/rosout", 10000, [this](const rosgraph_msgs::Log::ConstPtr& m) {
      std::lock_guard<std::mutex> lock(mutex_);
      log_.push_back(m->name + ": " + m->msg);
    });
    spinner_.start();
  }

  bool wait(const std::function<bool()>& done, double timeout_s = kPatience_s) {
    return mic::test::wait_for_condition(mutex_, done, timeout_s);
  }

  /// The latest value of `key` in the status `node: record files`; "" before it.
  std::string diagnostic(const std::string& node, const std::string& key) {
    for (const auto& [name, values] : diagnostics_by_name_) {
      if (name.find(node + ": record files") == std::string::npos) continue;
      const auto it = values.find(key);
      return it == values.end() ? "" : it->second;
    }
    return "";
  }
  std::size_t count(const std::string& node, const std::string& key) {
    const std::string text = diagnostic(node, key);
    return text.empty() ? 0 : static_cast<std::size_t>(std::stoull(text));
  }
  /// Waits until the node has looked at its files twice more: what was written before is read.
  bool wait_two_looks(const std::string& node) {
    std::size_t looks = 0;
    wait([&] { return (looks = count(node, "looks")) > 0; });
    return wait([&] { return count(node, "looks") >= looks + 2; });
  }
  bool logged(const std::string& part) {
    for (const std::string& line : log_) {
      if (line.find(part) != std::string::npos) return true;
    }
    return false;
  }

  std::mutex& mutex() { return mutex_; }
  const std::vector<Received>& received() const { return received_; }
  std::size_t received_count() {
    std::lock_guard<std::mutex> lock(mutex_);
    return received_.size();
  }

 private:
  ros::NodeHandle nh_;
  ros::AsyncSpinner spinner_;
  ros::Subscriber field_, diagnostics_, rosout_;
  std::mutex mutex_;
  std::vector<Received> received_;
  std::map<std::string, std::map<std::string, std::string>> diagnostics_by_name_;
  std::vector<std::string> log_;
};

const mic::VectorRecord& the_day() {
  static const mic::VectorRecord day = mic::read_iaga2002(mic::test::package_data("wic20250514_lemi036.sec.gz"));
  return day;
}

/// Each received sample is the day's record `records[i]` (values, tesla) at stamp `stamps_s[i]`,
/// in frame `frame_id`, covariance unknown; none more, none fewer.
void expect_received(const std::vector<Received>& got, const std::vector<std::size_t>& records,
                     const std::vector<double>& stamps_s, const std::string& frame_id) {
  ASSERT_EQ(got.size(), records.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    const auto k = static_cast<Eigen::Index>(records[i]);
    ASSERT_EQ(got[i].stamp_s, stamps_s[i]) << "message " << i;
    ASSERT_EQ(got[i].x_T, the_day().values_nT(k, 0) * 1e-9) << "message " << i;
    ASSERT_EQ(got[i].y_T, the_day().values_nT(k, 1) * 1e-9) << "message " << i;
    ASSERT_EQ(got[i].z_T, the_day().values_nT(k, 2) * 1e-9) << "message " << i;
    ASSERT_EQ(got[i].frame_id, frame_id);
    ASSERT_TRUE(got[i].covariance_zero);
  }
}

std::string follower_path() { return mic::test::sibling_executable("record_file_follower"); }

std::string lines_text(const std::vector<std::string>& lines) {
  std::string text;
  for (const std::string& line : lines) text += line + "\r\n";
  return text;
}

void append_text(const std::string& path, const std::string& text) {
  std::FILE* f = std::fopen(path.c_str(), "ab");
  ASSERT_NE(f, nullptr);
  std::fwrite(text.data(), 1, text.size(), f);
  std::fclose(f);
}

/// The node's private parameters for following `dir` onto `topic`, its state in dir/state/`state`.yaml.
std::vector<std::string> follower_arguments(const std::string& name, const std::string& dir, const std::string& topic,
                                            const std::string& state = "follower") {
  return {"__name:=" + name,        "_path:=" + dir,         "_topic:=" + topic,
          "_frame_id:=obs2",        "_state_file:=" + dir + "/state/" + state + ".yaml",
          "_poll_period:=0.2",      "_rate:=0",              "_diagnostic_period:=0.2",
          "_max_lag:=0"};
}

}  // namespace

TEST(RecordFileFollower, FollowsFilesThroughFaultsAndARestart) {
  const std::string dir = mic::test::make_temp_dir("follower_rostest");
  const std::string file = dir + "/wic20250514vsec.sec", topic = "/obs2/magnetic_field";
  const std::vector<std::string>& data = mic::test::wic_day().data;
  Listener listener(topic);
  std::vector<std::size_t> records;  // the day's records expected, in order
  std::vector<double> stamps;
  const auto expect = [&](std::size_t first, std::size_t last, double shift_s = 0.0) {
    for (std::size_t k = first; k < last; ++k) {
      records.push_back(k);
      stamps.push_back(mic::test::wic_time_s(k) + shift_s);
    }
  };
  const auto received_all = [&] { return listener.received().size() >= records.size(); };
  mic::test::ChildProcess node{mic::test::spawn_process(follower_path(), follower_arguments("follower_a", dir, topic))};
  ASSERT_GT(node.pid, 0);

  // The day so far, its last line being written (cut within its values): not published.
  mic::test::write_bytes(file, mic::test::iaga_text(mic::test::wic_lines(0, 1000), data[1000].substr(0, 40)));
  expect(0, 1000);
  ASSERT_TRUE(listener.wait(received_all)) << listener.received().size() << " of " << records.size();
  ASSERT_TRUE(listener.wait_two_looks("follower_a"));
  {
    std::lock_guard<std::mutex> lock(listener.mutex());
    EXPECT_EQ(listener.received().size(), 1000u) << "the line being written was published";
    EXPECT_EQ(listener.diagnostic("follower_a", "last line being written"), file);
    EXPECT_EQ(listener.diagnostic("follower_a", "station"), "WIC");
  }
  // The line is whole but has no line end yet (the readers' own rule would keep it): still not
  // published.
  append_text(file, data[1000].substr(40));
  ASSERT_TRUE(listener.wait_two_looks("follower_a"));
  EXPECT_EQ(listener.received_count(), 1000u) << "a line without its line end was published";
  // The line ends, more lines come; then the file is rewritten (a new download) with more lines.
  append_text(file, "\r\n" + lines_text(mic::test::wic_lines(1001, 2000)));
  expect(1000, 2000);
  ASSERT_TRUE(listener.wait(received_all)) << listener.received().size() << " of " << records.size();
  mic::test::write_bytes(dir + "/.download", mic::test::iaga_text(mic::test::wic_lines(0, 3000)));
  ASSERT_EQ(std::rename((dir + "/.download").c_str(), file.c_str()), 0);
  expect(2000, 3000);
  ASSERT_TRUE(listener.wait(received_all)) << listener.received().size() << " of " << records.size();

  // Files of another station and of another sample period: refused, named in a warning and the
  // diagnostics (WARN), nothing of them published.
  const std::string other_station = dir + "/ngk20250514vsec.sec", minutes = dir + "/wic20250514vmin.min";
  mic::test::write_bytes(other_station, mic::test::iaga_text(mic::test::wic_lines(3000, 3100), "", "NGK"));
  mic::test::write_bytes(minutes, mic::test::iaga_text(mic::test::wic_lines(0, 86400, 60)));
  ASSERT_TRUE(listener.wait([&] { return listener.count("follower_a", "files refused") == 2; }));
  ASSERT_TRUE(listener.wait([&] {
    return listener.logged("file refused: " + other_station + ": station 'NGK', not the stream's 'WIC'") &&
           listener.logged("file refused: " + minutes + ": sample period 60 s, not the stream's 1 s");
  })) << "the warnings naming the refused files";
  ASSERT_TRUE(listener.wait_two_looks("follower_a"));
  {
    std::lock_guard<std::mutex> lock(listener.mutex());
    const std::string refused = listener.diagnostic("follower_a", "refused files");
    EXPECT_NE(refused.find(other_station), std::string::npos) << refused;
    EXPECT_NE(refused.find(minutes), std::string::npos) << refused;
    EXPECT_EQ(listener.diagnostic("follower_a", "level"), "1");
    EXPECT_EQ(listener.received().size(), records.size());
  }

  // The remote's clock steps back 50 s (records 3000..3049 stamped 2950..2999: refused, counted),
  // runs on, then jumps 600 s ahead (records 3100..3109 published 600 s later: a gap).
  std::string more;
  for (std::size_t k = 3000; k < 3050; ++k) more += mic::test::wic_line_stamped(k, k - 50) + "\r\n";
  more += lines_text(mic::test::wic_lines(3050, 3100));
  for (std::size_t k = 3100; k < 3110; ++k) more += mic::test::wic_line_stamped(k, k + 600) + "\r\n";
  append_text(file, more);
  expect(3050, 3100);
  expect(3100, 3110, 600.0);
  ASSERT_TRUE(listener.wait(received_all)) << listener.received().size() << " of " << records.size();
  ASSERT_TRUE(listener.wait([&] { return listener.count("follower_a", "lines refused: stamp not after the line before") == 50; }));
  ASSERT_TRUE(listener.wait([&] { return listener.count("follower_a", "samples published") == records.size(); }));

  // Restarted mid-day: stopped while it waits for lines; the day grows while it is down.
  ASSERT_TRUE(node.stop()) << "the node did not stop on SIGINT";
  const mic::RecordFollowerState state = mic::read_follower_state(dir + "/state/follower.yaml");
  EXPECT_EQ(state.newest_s, mic::test::wic_time_s(3709));
  std::string later;
  for (std::size_t k = 3110; k < 5000; ++k) later += mic::test::wic_line_stamped(k, k + 600) + "\r\n";
  append_text(file, later);
  expect(3110, 5000, 600.0);
  mic::test::ChildProcess again{mic::test::spawn_process(follower_path(), follower_arguments("follower_b", dir, topic))};
  ASSERT_TRUE(listener.wait(received_all)) << listener.received().size() << " of " << records.size();
  ASSERT_TRUE(listener.wait_two_looks("follower_b"));
  std::lock_guard<std::mutex> lock(listener.mutex());
  expect_received(listener.received(), records, stamps, "obs2");
  EXPECT_EQ(listener.count("follower_b", "samples refused: not after the newest published"), 0u);
  EXPECT_EQ(listener.count("follower_b", "samples published"), 5000u - 3110u);
}

TEST(RecordFileFollower, ReplaysAnArchiveOnce) {
  // Hour 0 as IAGA-2002 gzip, hour 1 as ImagCDF, hour 2 as IAGA-2002 whose last line has no line
  // end (read at the replay's end): one stream, in order, once, then "replay finished".
  const std::string dir = mic::test::make_temp_dir("follower_replay"), topic = "/replay/magnetic_field";
  {
    mic::TextFileWriter gz(dir + "/wic_00.sec.gz");
    gz.write(mic::test::iaga_text(mic::test::wic_lines(0, 3600)));
    gz.close();
  }
  mic::VectorRecord hour = the_day();
  hour.time_s.assign(the_day().time_s.begin() + 3600, the_day().time_s.begin() + 7200);
  hour.values_nT = the_day().values_nT.middleRows(3600, 3600);
  hour.auxiliary.clear();
  mic::write_imagcdf(dir + "/wic_01.cdf", hour);
  const std::vector<std::string> last = mic::test::wic_lines(7200, 10800);
  mic::test::write_bytes(dir + "/wic_02.sec",
                         mic::test::iaga_text(std::vector<std::string>(last.begin(), last.end() - 1), last.back()));
  Listener listener(topic);
  std::vector<std::string> arguments = follower_arguments("replay", dir, topic);
  arguments.push_back("_follow:=false");
  arguments.push_back("_publisher_queue_size:=100000");  // ~rate 0: the whole replay may wait in the queue
  const ros::WallTime started = ros::WallTime::now();
  mic::test::ChildProcess node{mic::test::spawn_process(follower_path(), arguments)};
  ASSERT_TRUE(listener.wait([&] { return listener.received().size() >= 10800; }));
  const double took_s = (ros::WallTime::now() - started).toSec();
  ASSERT_TRUE(listener.wait([&] { return listener.diagnostic("replay", "message") == "replay finished"; }));
  std::printf("[ info ] 10800 samples of three files replayed at ~rate 0 in %.2f s (node start included)\n", took_s);
  std::vector<std::size_t> records;
  std::vector<double> stamps;
  for (std::size_t k = 0; k < 10800; ++k) {
    records.push_back(k);
    stamps.push_back(mic::test::wic_time_s(k));
  }
  {
    std::lock_guard<std::mutex> lock(listener.mutex());
    expect_received(listener.received(), records, stamps, "obs2");
    EXPECT_EQ(listener.count("replay", "files read"), 3u);
  }
  // At ~rate 5000 the same 10 799 s of stamps take at least 10 799 / 5000 = 2.16 s to arrive.
  Listener paced(topic + "_paced");
  arguments = follower_arguments("replay_paced", dir, topic + "_paced", "paced");
  arguments.insert(arguments.end(), {"_follow:=false", "_rate:=5000"});
  mic::test::ChildProcess paced_node{mic::test::spawn_process(follower_path(), arguments)};
  ASSERT_TRUE(paced.wait([&] { return paced.received().size() >= 10800; }));
  std::lock_guard<std::mutex> lock(paced.mutex());
  const double span_s = paced.received().back().arrival_wall_s - paced.received().front().arrival_wall_s;
  std::printf("[ info ] the same at ~rate 5000: %.2f s from the first sample to the last\n", span_s);
  EXPECT_GE(span_s, 10799.0 / 5000.0 - 0.05);
  expect_received(paced.received(), records, stamps, "obs2");
}

TEST(RecordFileFollower, ImpossibleParametersAreFatal) {
  const std::string dir = mic::test::make_temp_dir("follower_parameters");
  mic::test::write_bytes(dir + "/bad.yaml", "newest_published: soon\n");
  struct Case {
    std::string arguments, expected;
  };
  const std::vector<Case> cases = {
      {"", "parameter ~path: is required and not set"},
      {"_path:=" + dir + " _rate:=-1", "parameter ~rate: must be >= 0"},
      {"_path:=" + dir + " _poll_period:=0", "parameter ~poll_period: must be > 0"},
      {"_path:=" + dir + " _start:=yesterday", "parameter ~start:"},
      {"_path:=" + dir + " _state_file:=/proc/mic_none/state.yaml", "parameter ~state_file:"},
      {"_path:=" + dir + " _state_file:=" + dir + "/bad.yaml", "parameter ~state_file: " + dir + "/bad.yaml: newest_published: malformed"},
  };
  int index = 0;
  for (const Case& c : cases) {
    const mic::test::RunResult r =
        mic::test::run_to_exit(follower_path() + " __name:=bad_follower_" + std::to_string(index++) + " " + c.arguments);
    EXPECT_EQ(r.exit_code, 1) << c.arguments << "\n" << r.output;
    EXPECT_NE(r.output.find(c.expected), std::string::npos) << c.arguments << ": expected '" << c.expected << "' in:\n"
                                                           << r.output;
    EXPECT_NE(r.output.find("FATAL"), std::string::npos) << r.output;
  }
}

TEST(RecordFileFollower, FollowsAsANodelet) {
  // The .test file's nodelet follows ~path (a folder that does not exist when it starts).
  std::string dir, topic;
  ASSERT_TRUE(ros::param::get("~path", dir));
  ASSERT_TRUE(ros::param::get("~topic", topic));
  Listener listener(topic);
  ASSERT_EQ(::mkdir(dir.c_str(), 0755), 0) << dir;
  mic::test::write_bytes(dir + "/wic.sec", mic::test::iaga_text(mic::test::wic_lines(0, 500)));
  ASSERT_TRUE(listener.wait([&] { return listener.received().size() >= 500; }));
  std::vector<std::size_t> records;
  std::vector<double> stamps;
  for (std::size_t k = 0; k < 500; ++k) {
    records.push_back(k);
    stamps.push_back(mic::test::wic_time_s(k));
  }
  ASSERT_TRUE(listener.wait([&] { return listener.count("follower_nodelet", "samples published") == 500; }));
  std::lock_guard<std::mutex> lock(listener.mutex());
  expect_received(listener.received(), records, stamps, "obs2_nodelet");
  std::remove((dir + "/wic.sec").c_str());
  ::rmdir(dir.c_str());
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_record_file_follower");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
