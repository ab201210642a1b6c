// Following record files that grow and appear; see record_follower.hpp.
#include "magnetometer_insitu_calibration/formats/record_follower.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/common/time_steps.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"

#include <glob.h>
#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <stdexcept>
#include <utility>

namespace magnetometer_insitu_calibration {

namespace fs = std::filesystem;

namespace {

bool hidden(const fs::path& path) {
  const std::string name = path.filename().string();
  return name.empty() || name[0] == '.';
}

std::string lower(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

std::string joined(const std::array<std::string, 3>& parts) { return parts[0] + ", " + parts[1] + ", " + parts[2]; }

std::string seconds_text(double value_s) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g s", value_s);
  return buffer;
}

/// The value most of `values` have (the first of them on a tie); `values` not empty.
template <class T>
T most_common(const std::vector<T>& values) {
  std::size_t best = 0, best_count = 0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    const auto count = static_cast<std::size_t>(std::count(values.begin(), values.end(), values[i]));
    if (count > best_count) best = i, best_count = count;
  }
  return values[best];
}

/// Drops the samples stamped after `latest_s` (a record of increasing times: a suffix); how many.
std::size_t drop_samples_after(VectorRecord& record, double latest_s) {
  const auto end = std::upper_bound(record.time_s.begin(), record.time_s.end(), latest_s);
  const auto keep = static_cast<std::size_t>(end - record.time_s.begin());
  const std::size_t dropped = record.size() - keep;
  if (dropped == 0) return 0;
  record.time_s.resize(keep);
  record.values_nT.conservativeResize(static_cast<Eigen::Index>(keep), 3);
  for (AuxiliaryChannel& channel : record.auxiliary) channel.values.resize(keep);
  return dropped;
}

}  // namespace

std::vector<std::string> list_followed_files(const std::string& path, const std::string& ignored) {
  std::vector<std::string> found;
  std::error_code error;
  if (fs::is_directory(path, error)) {
    for (fs::directory_iterator it(path, error), end; !error && it != end; it.increment(error)) {
      found.push_back(it->path().string());
    }
  } else {
    glob_t matches{};
    if (::glob(path.c_str(), 0, nullptr, &matches) == 0) {
      for (std::size_t i = 0; i < matches.gl_pathc; ++i) found.emplace_back(matches.gl_pathv[i]);
    }
    ::globfree(&matches);
  }
  std::vector<std::string> files;
  for (const std::string& candidate : found) {
    std::error_code e;
    if (hidden(candidate) || !fs::is_regular_file(candidate, e)) continue;
    if (!ignored.empty() && fs::equivalent(candidate, ignored, e)) continue;
    files.push_back(candidate);
  }
  std::sort(files.begin(), files.end());
  return files;
}

struct RecordFileFollower::Read {
  std::size_t file = 0;  ///< index in files_
  VectorRecord record;
  bool ok = false;
  bool held = false;  ///< read with complete_lines_only
};

RecordFileFollower::RecordFileFollower(RecordFollowerSettings settings, RecordFollowerState resumed)
    : settings_(std::move(settings)), state_(std::move(resumed)), resumed_newest_s_(state_.newest_s) {
  if (!settings_.station.empty()) state_.station = settings_.station;
  if (settings_.sample_period_s > 0.0) state_.sample_period_s = settings_.sample_period_s;
  state_.path = settings_.path;
}

RecordFileFollower::Read RecordFileFollower::read_file(FollowedFile& file, double now_s, bool hold,
                                                       std::vector<std::string>& warnings) {
  Read r;
  r.held = hold;
  ++counts_.file_reads;
  TextReadOptions text;
  text.complete_lines_only = hold;
  text.skip_out_of_order = true;
  text.latest_time_s = now_s + settings_.ahead_tolerance_s;
  std::vector<std::string> reader_warnings;
  try {
    r.record = read_record(file.path, settings_.lemi, &reader_warnings, text);
  } catch (const std::exception& e) {  // InputError naming file and line, or a file system error
    file.refused = e.what();
    ++counts_.refusals;
    warnings.push_back(std::string("file refused: ") + e.what());
    return r;
  }
  for (const std::string& w : reader_warnings) warnings.push_back(w);
  // The text readers skip out-of-order lines themselves; the binary formats' readers keep times
  // increasing, and the ahead-of-the-clock rule is applied here.
  const std::map<std::string, std::string>& header = r.record.header;
  const std::size_t backwards = noted_count(header, kLinesBackwardsKey);
  const std::size_t ahead = noted_count(header, kLinesAheadKey) + drop_samples_after(r.record, text.latest_time_s);
  const std::size_t new_backwards = backwards > file.lines_backwards ? backwards - file.lines_backwards : 0;
  const std::size_t new_ahead = ahead > file.lines_ahead ? ahead - file.lines_ahead : 0;
  if (new_backwards + new_ahead > 0) {
    const auto first = header.find(kFirstSkippedLineKey);
    warnings.push_back(file.path + ": " + std::to_string(new_backwards + new_ahead) + " line(s) refused (" +
                       std::to_string(new_backwards) + " stamped not after the line before, " + std::to_string(new_ahead) +
                       " ahead of the clock)" + (first != header.end() ? "; the file's first: " + first->second : ""));
  }
  counts_.lines_backwards += new_backwards;
  counts_.lines_ahead += new_ahead;
  file.lines_backwards = backwards;
  file.lines_ahead = ahead;
  file.last_line_held = header.count(kHeldLastLineKey) > 0;
  file.samples = r.record.size();
  file.first_s = r.record.empty() ? std::numeric_limits<double>::quiet_NaN() : r.record.time_s.front();
  file.last_s = r.record.empty() ? std::numeric_limits<double>::quiet_NaN() : r.record.time_s.back();
  file.refused.clear();
  r.ok = true;
  return r;
}

void RecordFileFollower::settle_stream(const std::vector<Read>& reads) {
  std::vector<std::string> stations;
  std::vector<double> periods;
  std::vector<std::array<std::string, 3>> components;
  for (const Read& r : reads) {
    if (!r.ok || r.record.empty() || !mismatch(r.record).empty()) continue;
    if (!r.record.station.empty()) stations.push_back(r.record.station);
    if (r.record.size() >= 2) periods.push_back(std::round(median_time_step(r.record.time_s) * 1e6) / 1e6);
    components.push_back(r.record.components);
  }
  if (state_.station.empty() && !stations.empty()) state_.station = most_common(stations);
  if (!(state_.sample_period_s > 0.0) && !periods.empty()) state_.sample_period_s = most_common(periods);
  if (state_.components[0].empty() && !components.empty()) state_.components = most_common(components);
}

std::string RecordFileFollower::mismatch(const VectorRecord& record) const {
  for (const std::string& c : record.components) {
    if (lower(c) == "d" || lower(c) == "i") return "component " + c + " is an angle, not a field component in nT";
  }
  if (!record.station.empty() && !state_.station.empty() && lower(record.station) != lower(state_.station)) {
    return "station '" + record.station + "', not the stream's '" + state_.station + "'";
  }
  if (record.size() >= 2 && state_.sample_period_s > 0.0) {
    const double period_s = median_time_step(record.time_s);
    if (std::fabs(period_s - state_.sample_period_s) > 0.01 * state_.sample_period_s) {
      return "sample period " + seconds_text(period_s) + ", not the stream's " + seconds_text(state_.sample_period_s);
    }
  }
  if (!record.empty() && !state_.components[0].empty() && record.components != state_.components) {
    return "components " + joined(record.components) + ", not the stream's " + joined(state_.components);
  }
  return "";
}

void RecordFileFollower::collect(FollowedFile& file, const VectorRecord& record, std::vector<std::string>& warnings,
                                 std::vector<std::pair<double, Eigen::Vector3d>>& out) {
  std::size_t late = 0;
  double late_first_s = 0.0, late_last_s = 0.0;
  for (std::size_t i = 0; i < record.size(); ++i) {
    const double t = record.time_s[i];
    if (!(t > file.handled_through_s)) continue;  // handled at an earlier read
    if (!(t > state_.newest_s)) {
      if (late++ == 0) late_first_s = t;
      late_last_s = t;
      continue;
    }
    out.emplace_back(t, record.values_nT.row(static_cast<Eigen::Index>(i)).transpose());
  }
  if (late > 0) {
    counts_.not_after_newest += late;
    warnings.push_back(file.path + ": " + std::to_string(late) + " sample(s) from " + time_for_message(late_first_s) +
                       " to " + time_for_message(late_last_s) + " not after the newest handed out, " +
                       time_for_message(state_.newest_s) + ": refused");
  }
  if (!record.empty()) file.handled_through_s = std::max(file.handled_through_s, record.time_s.back());
}

FollowerLook RecordFileFollower::look(double now_s, bool final) {
  FollowerLook out;
  ++counts_.looks;
  // The files now, each with what the last look knew of it.
  std::vector<FollowedFile> files;
  std::vector<std::size_t> changed;
  for (const std::string& path : list_followed_files(settings_.path, settings_.ignored_path)) {
    struct stat info {};
    if (::stat(path.c_str(), &info) != 0) continue;  // gone since the listing
    const auto known = std::find_if(files_.begin(), files_.end(), [&](const FollowedFile& f) { return f.path == path; });
    FollowedFile f;
    if (known != files_.end()) {
      f = *known;
    } else {
      f.path = path;
      f.handled_through_s = first_look_ ? resumed_newest_s_ : -std::numeric_limits<double>::infinity();
    }
    const long long mtime_ns = static_cast<long long>(info.st_mtim.tv_sec) * 1000000000LL + info.st_mtim.tv_nsec;
    const bool is_changed = known == files_.end() || f.size != static_cast<std::uintmax_t>(info.st_size) ||
                            f.mtime_ns != mtime_ns || f.inode != static_cast<std::uintmax_t>(info.st_ino);
    f.size = static_cast<std::uintmax_t>(info.st_size);
    f.mtime_ns = mtime_ns;
    f.inode = static_cast<std::uintmax_t>(info.st_ino);
    if (is_changed) changed.push_back(files.size());
    files.push_back(std::move(f));
  }
  files_ = std::move(files);
  std::vector<Read> reads;
  for (std::size_t i : changed) {
    reads.push_back(read_file(files_[i], now_s, !final, out.warnings));
    reads.back().file = i;
  }
  // A file whose last line waits for its line end is finished when another file begins after it.
  for (std::size_t i = 0; i < files_.size(); ++i) {
    const FollowedFile& f = files_[i];
    if (!f.last_line_held || !f.refused.empty()) continue;
    const bool finished = final || std::any_of(files_.begin(), files_.end(), [&](const FollowedFile& g) {
                            return g.refused.empty() && g.samples > 0 && g.first_s > f.last_s;
                          });
    if (!finished) continue;
    Read again = read_file(files_[i], now_s, false, out.warnings);
    again.file = i;
    const auto before = std::find_if(reads.begin(), reads.end(), [&](const Read& r) { return r.file == i; });
    if (before != reads.end()) *before = std::move(again);
    else reads.push_back(std::move(again));
  }
  std::sort(reads.begin(), reads.end(), [](const Read& a, const Read& b) { return a.file < b.file; });
  settle_stream(reads);
  std::vector<std::pair<double, Eigen::Vector3d>> samples;
  for (Read& r : reads) {
    if (!r.ok) continue;
    FollowedFile& f = files_[r.file];
    const std::string why = mismatch(r.record);
    if (!why.empty()) {
      f.refused = f.path + ": " + why;
      ++counts_.refusals;
      out.warnings.push_back("file refused: " + f.refused);
      continue;
    }
    collect(f, r.record, out.warnings, samples);
  }
  // One time order over the files; a stamp two files share is handed out once.
  std::stable_sort(samples.begin(), samples.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  VectorRecord& record = out.samples;
  record.source = settings_.path;
  record.station = state_.station;
  if (!state_.components[0].empty()) record.components = state_.components;
  record.values_nT.resize(static_cast<Eigen::Index>(samples.size()), 3);
  std::size_t shared = 0;
  for (const auto& [t, value] : samples) {
    if (!record.time_s.empty() && !(t > record.time_s.back())) {
      ++shared;
      continue;
    }
    record.values_nT.row(static_cast<Eigen::Index>(record.time_s.size())) = value.transpose();
    record.time_s.push_back(t);
  }
  record.values_nT.conservativeResize(static_cast<Eigen::Index>(record.time_s.size()), 3);
  if (shared > 0) {
    counts_.not_after_newest += shared;
    out.warnings.push_back(std::to_string(shared) + " sample(s) stamped as a sample of another file of the same look: "
                           "the first file's kept");
  }
  if (!record.empty()) state_.newest_s = record.time_s.back();
  counts_.samples += record.size();
  first_look_ = false;
  return out;
}

}  // namespace magnetometer_insitu_calibration
