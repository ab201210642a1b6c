// record_file_follower, diagnostics: the /diagnostics task "record files" (see
// record_file_follower.hpp).
#include "magnetometer_insitu_calibration/ros/record_file_follower.hpp"

#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/ros/parameters.hpp"

#include <cmath>
#include <cstdio>

namespace magnetometer_insitu_calibration {

namespace {

using diagnostic_msgs::DiagnosticStatus;

/// Whole seconds as text ("48756500"), for lags that %g would print with an exponent.
std::string whole_seconds(double value_s) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.0f", value_s);
  return buffer;
}

/// Up to `most` texts joined by "; ", then how many more.
std::string listed_texts(const std::vector<std::string>& texts, std::size_t most = 5) {
  std::string out;
  for (std::size_t i = 0; i < texts.size() && i < most; ++i) out += (i > 0 ? "; " : "") + texts[i];
  if (texts.size() > most) out += "; and " + std::to_string(texts.size() - most) + " more";
  return texts.empty() ? std::string("none") : out;
}

}  // namespace

void RecordFileFollowerNode::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  Figures f;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    f = figures_;
  }
  const double now_s = ros::WallTime::now().toSec();
  std::vector<std::string> refused, held;
  for (const FollowedFile& file : f.files) {
    if (!file.refused.empty()) refused.push_back(file.refused);
    if (file.last_line_held && file.refused.empty()) held.push_back(file.path);
  }
  const bool any_published = std::isfinite(f.newest_published_s);
  const double lag_s = any_published ? now_s - f.newest_published_s : std::numeric_limits<double>::quiet_NaN();

  // The level: the worst of what needs a look.
  int level = DiagnosticStatus::OK;
  std::string message = settings_.follow ? "following" : (f.replay_finished ? "replay finished" : "replaying");
  const auto raise = [&](int at, const std::string& why) {
    if (at > level) message = why;
    level = std::max(level, at);
  };
  if (f.counts.looks > 0 && f.files.empty()) raise(DiagnosticStatus::WARN, "no file matches " + settings_.path);
  if (!refused.empty()) raise(DiagnosticStatus::WARN, std::to_string(refused.size()) + " file(s) refused");
  if (f.lines_refused_last_look > 0) {
    raise(DiagnosticStatus::WARN, std::to_string(f.lines_refused_last_look) + " line(s) refused by the last look");
  }
  if (settings_.follow && settings_.max_lag_s > 0.0 && any_published && lag_s > settings_.max_lag_s) {
    raise(DiagnosticStatus::WARN, "newest stamp " + whole_seconds(lag_s) + " s behind the clock");
  }
  if (!f.look_error.empty()) raise(DiagnosticStatus::ERROR, "look failed: " + f.look_error);
  if (!f.state_error.empty()) raise(DiagnosticStatus::ERROR, "state file not written: " + f.state_error);
  status.summary(static_cast<unsigned char>(level), message);

  status.add("path", settings_.path);
  status.add("topic", nh_.resolveName(settings_.topic));
  status.add("mode", settings_.follow ? "follow, a look every " + number_text(settings_.poll_period_s) + " s"
                                      : std::string("replay"));
  status.add("files matched", f.files.size());
  status.add("files read", f.counts.file_reads);
  status.add("files refused", refused.size());
  status.add("refused files", listed_texts(refused));
  status.add("last line being written", listed_texts(held));
  status.add("samples published", f.published);
  status.add("newest stamp", any_published ? time_for_message(f.newest_published_s) : std::string("none"));
  status.add("lag behind wall time (s)", any_published ? whole_seconds(lag_s) : std::string("none"));
  status.add("lines refused", f.counts.lines_refused());
  status.add("lines refused: stamp not after the line before", f.counts.lines_backwards);
  status.add("lines refused: ahead of the clock", f.counts.lines_ahead);
  status.add("samples refused: not after the newest published", f.counts.not_after_newest);
  status.add("station", f.stream.station.empty() ? std::string("not known yet") : f.stream.station);
  status.add("sample period (s)", f.stream.sample_period_s > 0.0 ? number_text(f.stream.sample_period_s) : "not known yet");
  status.add("components", f.stream.components[0].empty()
                               ? std::string("not known yet")
                               : f.stream.components[0] + ", " + f.stream.components[1] + ", " + f.stream.components[2]);
  status.add("waiting for subscribers", f.waiting_for_subscribers);
  status.add("looks", f.counts.looks);
  status.add("last look", f.counts.looks > 0 ? time_for_message(f.last_look_wall_s) : std::string("none"));
  status.add("last look took (s)", number_text(f.last_look_duration_s));
  status.add("state file", settings_.state_file.empty() ? std::string("none") : settings_.state_file);
  status.add("state file written", f.state_written.empty() ? std::string("not yet") : f.state_written);
}

}  // namespace magnetometer_insitu_calibration
