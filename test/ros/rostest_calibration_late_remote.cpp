// rostest_calibration, a neighbouring observatory's record files as a late live remote
// (late_remote.test):
//   Calibration.LateRemoteFiles  the test publishes a simulated pair (1 s, 13.5 h) into
//       calibration_node and writes a simulated remote observatory's record as one IAGA-2002 day
//       file, appended in chunks of 30 min whose stamps are 2 h behind the pair's;
//       record_file_follower follows the folder onto the node's ~remote_topic. Windows of 2 h
//       every hour, ~remote_max_wait 3 h. The remote stops after 4.5 h of its stamps (the pair at
//       6.5 h) and returns with its backlog when the pair is at 10.5 h:
//       - the windows it covers (starts 0-2 h, 6-9 h) wait for it, use it (first-stage F >= 10)
//         and equal the offline path (prepare_pair, prepare_sides with the file read back,
//         window_records, WindowCalibrator: calibrate_records --remote) on the same samples;
//       - the windows after its stop come out only once the pair is ~remote_max_wait past their
//         ends: the one it covers in part (start 3 h) says how far it had reached; those it
//         covers in a quarter or not at all (4 h, 5 h) are the pair's, equal the offline path
//         without a remote and say why;
//       - no window comes out before its remote reached its end or the pair left it
//         ~remote_max_wait behind.
// Waits are for conditions (a window's message, the node's count of remote messages).
#include "calibration_harness.hpp"
#include "station_offline_window.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"
#include "magnetometer_insitu_calibration/simulation/remote_observatory.hpp"

#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

using namespace calibration_rostest;

namespace late_remote {

constexpr std::size_t kChunk = 1800;      ///< samples (s of stamps) per step of the pair and the remote
constexpr std::size_t kLag = 7200;        ///< the remote's stamps behind the pair's, s
constexpr std::size_t kStopAt = 23400;    ///< the remote stops when the pair reaches this (6.5 h)
constexpr std::size_t kReturnAt = 37800;  ///< and returns with its backlog at 10.5 h
constexpr std::size_t kDuration = 48600;  ///< the pair's samples (13.5 h)

/// The remote's record as a neighbouring observatory's day file, written as its samples arrive:
/// the first chunk with the IAGA-2002 header (by a rename), the others appended line by line.
class RemoteDayFile {
 public:
  RemoteDayFile(std::string folder, const mic::VectorRecord& remote)
      : folder_(std::move(folder)), remote_(remote), path_(folder_ + "/rmt20250514vsec.sec") {}

  const std::string& path() const { return path_; }
  std::size_t written() const { return written_; }

  /// Appends samples [written(), last).
  void append_to(std::size_t last) {
    if (last <= written_) return;
    mic::VectorRecord chunk = remote_;
    chunk.time_s.assign(remote_.time_s.begin() + static_cast<std::ptrdiff_t>(written_),
                        remote_.time_s.begin() + static_cast<std::ptrdiff_t>(last));
    chunk.values_nT = remote_.values_nT.middleRows(static_cast<Eigen::Index>(written_),
                                                   static_cast<Eigen::Index>(last - written_));
    const std::string scratch = folder_ + "/.chunk.sec";
    mic::Iaga2002WriteOptions options;
    options.iaga_code = "RMT";
    options.station_name = "Remote";
    mic::write_iaga2002(scratch, chunk, options);
    if (written_ == 0) {
      ASSERT_EQ(std::rename(scratch.c_str(), path_.c_str()), 0) << path_;
    } else {
      std::ifstream in(scratch, std::ios::binary);
      std::stringstream text;
      text << in.rdbuf();
      const std::string all = text.str();
      const std::size_t header = all.find("\r\nDATE ");
      ASSERT_NE(header, std::string::npos);
      const std::size_t data = all.find("\r\n", header + 2) + 2;  // the line after the column header
      std::ofstream out(path_, std::ios::binary | std::ios::app);
      out << all.substr(data);
      std::remove(scratch.c_str());
    }
    written_ = last;
  }

 private:
  std::string folder_;
  const mic::VectorRecord& remote_;
  std::string path_;
  std::size_t written_ = 0;
};

/// What the node may and must have published when the pair reached `pair_to` and the remote
/// `remote_to` (samples from the start, exclusive ends).
struct Progress {
  double window_s = 0.0, max_wait_s = 0.0;

  double end_of(double start_offset_s) const { return start_offset_s + window_s - 1.0; }
  /// A window its remote reaches (the despiker holds a stream's last 15 samples) or the pair has
  /// left max_wait_s behind.
  bool due(double start_offset_s, std::size_t pair_to, std::size_t remote_to) const {
    const double end = end_of(start_offset_s), pair = static_cast<double>(pair_to) - 1.0;
    return (static_cast<double>(remote_to) - 1.0 >= end + 60.0 && pair >= end + 60.0) || pair > end + max_wait_s + 60.0;
  }
  /// Neither: the node cannot have released it.
  bool held(double start_offset_s, std::size_t pair_to, std::size_t remote_to) const {
    const double end = end_of(start_offset_s);
    return static_cast<double>(remote_to) - 1.0 < end && static_cast<double>(pair_to) - 1.0 - end <= max_wait_s;
  }
};

/// calibrate_records --remote's path on the whole records: the prepared pair and remote, and the
/// per-window stage with the node's settings (read from the parameter server).
struct Offline {
  Offline(const mic::SimulatedPair& pair, const mic::VectorRecord& remote, const std::string& node)
      : settings(mic::CalibrationNodeSettings::load(ros::NodeHandle(node))) {
    mic::CalibrationSettings calibration;
    calibration.preprocess = station_rostest::preprocess_of(settings.streams);
    calibration.window = settings.window;
    prepared = mic::prepare_pair(pair.reference, pair.test, calibration.preprocess);
    sides = mic::prepare_sides(pair.reference, prepared, {nullptr, &remote}, calibration);
  }

  /// The window starting at start_s, with the remote or without.
  mic::CalibrationWindow window(double start_s, bool with_remote) const {
    const auto& grid = prepared.paired.time_s;
    const auto at = std::lower_bound(grid.begin(), grid.end(), start_s - 0.25 * prepared.sample_period_s);
    EXPECT_TRUE(at != grid.end() && std::abs(*at - start_s) < 0.25 * prepared.sample_period_s) << start_s;
    const auto count = static_cast<std::size_t>(std::llround(settings.streams.window_s / prepared.sample_period_s));
    mic::WindowCalibrator calibrator(settings.window);
    return calibrator.calibrate(mic::window_records(prepared, static_cast<std::size_t>(at - grid.begin()), count,
                                                    settings.streams.temperature_margin_s, with_remote ? &sides : nullptr));
  }

  mic::CalibrationNodeSettings settings;
  mic::PreparedPair prepared;
  mic::PreparedSides sides;
};

/// max |n_live - n_offline| / max |n_offline|.
double relative_difference(const mic::MagnetometerCalibration& live, const mic::CalibrationWindow& offline) {
  const Eigen::Matrix3d& n = offline.estimate.n;
  return (matrix_of(live) - n).cwiseAbs().maxCoeff() / n.cwiseAbs().maxCoeff();
}

/// The live message of the window starting at start_s (null: none yet); lock h.mutex().
const mic::MagnetometerCalibration* message_at(Harness& h, double start_s) {
  for (const auto& c : h.calibrations()) {
    if (std::abs(c.window_start.toSec() - start_s) < 0.5) return &c;
  }
  return nullptr;
}

/// Each window the remote covers used it and equals the offline path on the same samples.
void expect_remote_windows(Harness& h, const Offline& offline, const std::vector<double>& starts_s) {
  for (double start : starts_s) {
    const mic::MagnetometerCalibration* c = message_at(h, start);
    ASSERT_NE(c, nullptr) << start;
    const std::string when = mic::format_iso8601(start, 0);
    EXPECT_TRUE(c->remote_used) << when << ": " << c->remote_text;
    EXPECT_GE(c->remote_strength, 10.0) << when << ": " << c->remote_text;
    EXPECT_EQ(c->remote_text.find("had reached"), std::string::npos) << when << ": " << c->remote_text;
    const mic::CalibrationWindow o = offline.window(start, true);
    EXPECT_TRUE(o.estimate.remote.used) << when << ": " << o.estimate.remote.text;
    EXPECT_EQ(c->samples, o.estimate.samples) << when;
    const double d = relative_difference(*c, o);
    std::printf("[ info ] window %s on the remote (F %.1f): |n_live - n_offline| / |n| = %.2e\n", when.c_str(),
                c->remote_strength, d);
    EXPECT_LE(d, 1e-9) << when;
  }
}

/// The remote text's "the remote had reached N s before the window's end when the pair was W s
/// past it": N from the window's end to the remote's last sample written (the despiker holds the
/// stream's last 15), W the node's ~remote_max_wait.
void expect_reached_text(const std::string& text, double behind_s, double max_wait_s) {
  const std::string lead = "the remote had reached ";
  const std::size_t at = text.find(lead);
  ASSERT_NE(at, std::string::npos) << text;
  const double n = std::stod(text.substr(at + lead.size()));
  EXPECT_GE(n, behind_s) << text;
  EXPECT_LE(n, behind_s + 60.0) << text;
  char rest[120];
  std::snprintf(rest, sizeof rest, " s before the window's end when the pair was %g s past it", max_wait_s);
  EXPECT_NE(text.find(rest, at), std::string::npos) << text;
}

/// Each window the remote stopped short of is the pair's, says why and equals the offline path
/// without a remote.
void expect_pair_only_windows(Harness& h, const Offline& offline, const std::vector<double>& starts_s,
                              double remote_last_s, double max_wait_s) {
  for (double start : starts_s) {
    const mic::MagnetometerCalibration* c = message_at(h, start);
    ASSERT_NE(c, nullptr) << start;
    const std::string when = mic::format_iso8601(start, 0);
    EXPECT_FALSE(c->remote_used) << when << ": " << c->remote_text;
    EXPECT_NE(c->remote_text.find("refused: it has samples at "), std::string::npos) << when << ": " << c->remote_text;
    expect_reached_text(c->remote_text, c->window_end.toSec() - remote_last_s, max_wait_s);
    const mic::CalibrationWindow o = offline.window(start, false);
    const double d = relative_difference(*c, o);
    std::printf("[ info ] window %s the pair's: %s; |n_live - n_offline| / |n| = %.2e\n", when.c_str(),
                c->remote_text.c_str(), d);
    EXPECT_LE(d, 1e-9) << when;
  }
}

}  // namespace late_remote

TEST(Calibration, LateRemoteFiles) {
  using namespace late_remote;
  mic::SimulationSettings sim = simulation(static_cast<double>(kDuration), 61);
  sim.keep_clean_field = true;  // the remote records the pair's field
  Harness h(sim);
  mic::RemoteObservatorySettings observatory;
  observatory.seed = 62;
  observatory.incoherent_fraction = observatory.z_incoherent_fraction = 0.1;
  const mic::VectorRecord remote = mic::simulate_remote_observatory(sim, h.pair(), observatory);
  const std::string folder = param("folder");
  ASSERT_FALSE(folder.empty());
  ASSERT_EQ(::mkdir(folder.c_str(), 0755), 0) << folder;
  RemoteDayFile file(folder, remote);
  ASSERT_TRUE(h.wait_for_connections(1, 1)) << "calibration_node did not connect";
  const std::string node = "/calibration_late";
  const mic::CalibrationNodeSettings settings = mic::CalibrationNodeSettings::load(ros::NodeHandle(node));
  const Progress progress{settings.streams.window_s, settings.streams.remote_max_wait_s};
  const double t0 = h.start_s(), step = settings.streams.step_s;
  std::vector<double> starts;  // window starts (offsets from t0) the test will see
  for (double s = 0.0; s + progress.window_s <= static_cast<double>(kDuration); s += step) starts.push_back(s);

  // Waits for the windows due with the pair at pair_to and the remote as written; none held back
  // has come.
  const auto expect_windows = [&](std::size_t pair_to) {
    const std::size_t remote_to = file.written();
    ASSERT_TRUE(h.wait([&] {
      for (double s : starts) {
        if (progress.due(s, pair_to, remote_to) && message_at(h, t0 + s) == nullptr) return false;
      }
      return true;
    }, kPatience_s)) << "a due window did not come with the pair at " << pair_to << " s, the remote at " << remote_to;
    std::lock_guard<std::mutex> lock(h.mutex());
    for (double s : starts) {
      EXPECT_FALSE(progress.held(s, pair_to, remote_to) && message_at(h, t0 + s) != nullptr)
          << "the window at +" << s << " s came out with the pair at " << pair_to << " s and the remote at " << remote_to;
    }
  };
  for (std::size_t pair_to = kChunk; pair_to <= kDuration; pair_to += kChunk) {
    h.publish(pair_to - kChunk, pair_to, true, true);
    expect_windows(pair_to);  // before the remote's chunk: those the pair alone releases are out
    ASSERT_FALSE(testing::Test::HasFatalFailure());
    const bool remote_on = pair_to <= kStopAt || pair_to >= kReturnAt;
    if (!remote_on || pair_to <= kLag) continue;
    file.append_to(pair_to - kLag);
    ASSERT_FALSE(testing::Test::HasFatalFailure());
    ASSERT_TRUE(h.wait_received({{"calibration_late: reference", "remote messages", file.written()}}, kPatience_s))
        << "the node did not receive the remote's " << file.written() << " samples";
    expect_windows(pair_to);
    ASSERT_FALSE(testing::Test::HasFatalFailure());
  }

  // The day file as calibrate_records --remote reads it, against the windows' messages.
  const mic::VectorRecord remote_read = mic::read_iaga2002(file.path());
  ASSERT_EQ(remote_read.size(), file.written());
  const Offline offline(h.pair(), remote_read, node);
  std::lock_guard<std::mutex> lock(h.mutex());
  expect_remote_windows(h, offline, {t0, t0 + 3600.0, t0 + 7200.0, t0 + 21600.0, t0 + 25200.0, t0 + 28800.0, t0 + 32400.0});
  // The window the remote covers three quarters of: released late, saying how far it reached.
  const mic::MagnetometerCalibration* partial = message_at(h, t0 + 10800.0);
  ASSERT_NE(partial, nullptr);
  const double remote_last_s = t0 + static_cast<double>(kStopAt - kLag) - 1.0;
  expect_reached_text(partial->remote_text, partial->window_end.toSec() - remote_last_s, progress.max_wait_s);
  std::printf("[ info ] window +3 h, three quarters on the remote: used %d, %s\n", partial->remote_used,
              partial->remote_text.c_str());
  expect_pair_only_windows(h, offline, {t0 + 14400.0, t0 + 18000.0}, remote_last_s, progress.max_wait_s);
}
