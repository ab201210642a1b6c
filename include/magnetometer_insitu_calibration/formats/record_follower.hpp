// Following record files that grow and appear, as a remote observatory's daily files reach a
// station (a cron job fetching them minutes to hours late): each look lists the files of a
// directory or glob, reads those that are new or changed with the package's readers (read_record:
// every format of record_file.hpp) and hands out the samples after the newest one handed out
// before, in time order, each once. What a restart needs (that newest stamp, the stream's station,
// sample period and components) is a small state file. ROS-free: the record_file_follower node
// publishes what a look hands out.
//
// Rules of a look:
//  - a file is read when it is new, or its size, modification time or inode changed since the
//    last look (a file growing, rewritten at midnight with more lines, replaced by a rename);
//    names starting with '.' (a download in progress, a temporary file) and the ignored path (the
//    state file) are not records;
//  - the last line of a text file without a line end is being written: it is not read
//    (TextReadOptions::complete_lines_only) until it ends, or until the file is finished, that is
//    when another file begins after its last sample, or the look is final (the end of a replay);
//    a finished file's last line is then read by the readers' rule (kept when whole, dropped when
//    cut short);
//  - a line whose stamp is not after the line before it in its file (a clock stepped back, a
//    repeated line) or is more than ahead_tolerance_s after the clock (a clock stepped ahead) is
//    refused and counted, the rest of the file read (TextReadOptions::skip_out_of_order);
//  - a file of another station, sample period or components than the stream's is refused, named
//    in a warning; so is a file that does not read (a damaged line, not a record);
//  - the samples of all files read in a look are merged in time order; a sample at or before the
//    newest handed out (a late file, two files of the same samples, a clock stepped back between
//    looks) is refused and counted, except, in a file already read, those it held before (a
//    rewritten file's old lines) and, at the first look, those at or before the resumed stamp
//    (published before a restart).
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"
#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

struct RecordFollowerSettings {
  std::string path;                  ///< a directory (every file in it) or a glob pattern ("/data/obs2/wic*.sec")
  std::string station;               ///< the stream's station; "" = the files' own (most files of the first look)
  double sample_period_s = 0.0;      ///< the stream's median step, s; 0 = the files' own
  double ahead_tolerance_s = 300.0;  ///< a stamp later than the clock plus this is refused, s
  std::string ignored_path;          ///< a file the pattern may match that is not a record (the state file)
  LemiReadOptions lemi;              ///< LEMI files: field mode, time shift, checksum
};

/// What a restart needs; the state file's content (follower_state_text, parse_follower_state).
struct RecordFollowerState {
  double newest_s = -std::numeric_limits<double>::infinity();  ///< newest stamp published, UNIX s; -inf: none
  std::string station;                                       ///< "" = not known yet
  double sample_period_s = 0.0;                              ///< s; 0 = not known yet
  std::array<std::string, 3> components;                     ///< "" = not known yet
  std::string path;                                          ///< the followed path or pattern
};

/// The state file's text (YAML): newest_published (17 significant digits, read back exactly, with
/// its ISO 8601 time as a comment), station, sample_period, components, path.
std::string follower_state_text(const RecordFollowerState& state);
/// Parses follower_state_text; throws InputError(source, ...) naming the key that is missing or
/// malformed.
RecordFollowerState parse_follower_state(const std::string& text, const std::string& source);
/// The state file at `path`: the default state when it does not exist; throws InputError for a
/// file that cannot be read or parsed.
RecordFollowerState read_follower_state(const std::string& path);

/// One file as the follower last found it.
struct FollowedFile {
  std::string path;
  std::uintmax_t size = 0;  ///< bytes
  long long mtime_ns = 0;   ///< modification time, ns since the UNIX epoch
  std::uintmax_t inode = 0;
  std::size_t samples = 0;  ///< samples of its last read
  double first_s = std::numeric_limits<double>::quiet_NaN();  ///< its first sample, UNIX s
  double last_s = std::numeric_limits<double>::quiet_NaN();   ///< its last sample, UNIX s
  double handled_through_s = -std::numeric_limits<double>::infinity();  ///< its samples up to here are handled
  bool last_line_held = false;  ///< its last line has no line end yet: not read
  std::string refused;          ///< why it is refused; "" = it is read
  std::size_t lines_backwards = 0, lines_ahead = 0;  ///< as its last read counted them
};

struct RecordFollowerCounts {
  std::size_t looks = 0;
  std::size_t file_reads = 0;      ///< files read (a file is read again each time it changes)
  std::size_t refusals = 0;        ///< files refused (again each time a refused file changes)
  std::size_t samples = 0;         ///< samples handed out
  std::size_t lines_backwards = 0; ///< lines stamped not after the line before in their file
  std::size_t lines_ahead = 0;     ///< lines stamped more than ahead_tolerance_s after the clock
  std::size_t not_after_newest = 0;  ///< samples at or before the newest handed out
  std::size_t lines_refused() const { return lines_backwards + lines_ahead + not_after_newest; }
};

/// What one look found.
struct FollowerLook {
  VectorRecord samples;               ///< new samples, nT, times strictly increasing after the newest handed out before
  std::vector<std::string> warnings;  ///< files and lines refused, each naming its file
};

class RecordFileFollower {
 public:
  /// Resumes from `resumed` (a state file's; its path is not checked here). Its station, period
  /// and components, where known, are the stream's unless the settings give them.
  explicit RecordFileFollower(RecordFollowerSettings settings, RecordFollowerState resumed = RecordFollowerState());

  /// Lists the files, reads the new and changed ones and returns the samples not handed out yet.
  /// now_s: the clock, UNIX s (the ahead-of-the-clock rule). final: nothing is being written any
  /// more (the end of a replay): last lines without a line end are read too.
  FollowerLook look(double now_s, bool final = false);

  /// newest_s = the newest sample handed out; the stream's station, period and components.
  const RecordFollowerState& state() const { return state_; }
  /// The files of the last look, by name.
  const std::vector<FollowedFile>& files() const { return files_; }
  const RecordFollowerCounts& counts() const { return counts_; }
  const RecordFollowerSettings& settings() const { return settings_; }

 private:
  struct Read;
  Read read_file(FollowedFile& file, double now_s, bool hold, std::vector<std::string>& warnings);
  void settle_stream(const std::vector<Read>& reads);
  std::string mismatch(const VectorRecord& record) const;
  void collect(FollowedFile& file, const VectorRecord& record, std::vector<std::string>& warnings,
               std::vector<std::pair<double, Eigen::Vector3d>>& out);

  RecordFollowerSettings settings_;
  RecordFollowerState state_;
  RecordFollowerCounts counts_;
  std::vector<FollowedFile> files_;
  double resumed_newest_s_;
  bool first_look_ = true;
};

/// The record files a follower's path names, sorted: a directory's regular files, or a glob
/// pattern's; names starting with '.' and `ignored` left out.
std::vector<std::string> list_followed_files(const std::string& path, const std::string& ignored = "");

}  // namespace magnetometer_insitu_calibration
