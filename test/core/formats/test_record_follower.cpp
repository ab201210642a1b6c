// RecordFileFollower (record_follower.hpp) on pieces of the real WIC day written as a remote
// observatory's files reach a station: a day written line by line with its last line cut, a file
// rewritten with more lines, files of another station and sample period beside it, a clock that
// steps back and ahead, a restart from the state file, several files a day and a gap. Every
// sample handed out is the day's own sample (time and value), in time order, once.
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/formats/record_follower.hpp"
#include "wic_day_pieces.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <limits>
#include <string>

namespace mic = magnetometer_insitu_calibration;

namespace {

/// The clock of the looks: an hour after the day (nothing of it is ahead).
const double kAfterTheDay_s = mic::test::wic_time_s(86400) + 3600.0;

const mic::VectorRecord& whole_wic_day() {
  static const mic::VectorRecord day = mic::read_iaga2002(mic::test::package_data("wic20250514_lemi036.sec.gz"));
  return day;
}

/// Every sample of `got` is the day's sample of its time, times strictly increasing, and they are
/// the day's samples [first, last) but those in `missing` (indices).
void expect_day_samples(const mic::VectorRecord& got, std::size_t first, std::size_t last,
                        const std::vector<std::size_t>& missing = {}) {
  std::size_t i = 0;
  for (std::size_t k = first; k < last; ++k) {
    if (std::find(missing.begin(), missing.end(), k) != missing.end()) continue;
    ASSERT_LT(i, got.size()) << "day sample " << k << " not handed out";
    ASSERT_EQ(got.time_s[i], mic::test::wic_time_s(k)) << "sample " << i;
    ASSERT_EQ(got.values_nT.row(static_cast<Eigen::Index>(i)), whole_wic_day().values_nT.row(static_cast<Eigen::Index>(k)))
        << "sample " << i;
    ++i;
  }
  EXPECT_EQ(i, got.size()) << "samples handed out beyond the day's [" << first << ", " << last << ")";
}

/// Writes `text` to `path` as a download does: a temporary file beside it, then renamed over it.
void replace_file(const std::string& path, const std::string& text) {
  const std::string temporary = path.substr(0, path.rfind('/') + 1) + ".download.tmp";
  mic::test::write_bytes(temporary, text);
  ASSERT_EQ(std::rename(temporary.c_str(), path.c_str()), 0);
}

void append_bytes(const std::string& path, const std::string& text) {
  std::FILE* f = std::fopen(path.c_str(), "ab");
  ASSERT_NE(f, nullptr);
  std::fwrite(text.data(), 1, text.size(), f);
  std::fclose(f);
}

std::string lines_text(const std::vector<std::string>& lines) {
  std::string text;
  for (const std::string& line : lines) text += line + "\r\n";
  return text;
}

mic::RecordFollowerSettings follow(const std::string& path) {
  mic::RecordFollowerSettings s;
  s.path = path;
  return s;
}

bool any_warning_has(const std::vector<std::string>& warnings, const std::string& part) {
  return std::any_of(warnings.begin(), warnings.end(), [&](const std::string& w) { return w.find(part) != std::string::npos; });
}

}  // namespace

TEST(RecordFollower, ADayWrittenLineByLineIsHandedOutOnceItsLinesAreComplete) {
  const std::string dir = mic::test::make_temp_dir("follower_growing");
  const std::string path = dir + "/wic20250514vsec.sec";
  const std::vector<std::string>& data = mic::test::wic_day().data;
  mic::test::write_bytes(path, mic::test::iaga_text(mic::test::wic_lines(0, 1000), data[1000].substr(0, 50)));
  mic::RecordFileFollower follower(follow(dir));
  mic::FollowerLook look = follower.look(kAfterTheDay_s);
  expect_day_samples(look.samples, 0, 1000);
  EXPECT_TRUE(look.warnings.empty()) << look.warnings.front();
  ASSERT_EQ(follower.files().size(), 1u);
  EXPECT_TRUE(follower.files()[0].last_line_held);
  EXPECT_EQ(follower.state().station, "WIC");
  EXPECT_EQ(follower.state().sample_period_s, 1.0);
  EXPECT_EQ(follower.state().components, (std::array<std::string, 3>{"H", "E", "Z"}));
  // The line grows, whole but still without its line end: not read yet.
  append_bytes(path, data[1000].substr(50));
  EXPECT_TRUE(follower.look(kAfterTheDay_s).samples.empty());
  // It ends, more follow, the next one cut within its digits.
  append_bytes(path, "\r\n" + lines_text(mic::test::wic_lines(1001, 2000)) + data[2000].substr(0, 66));
  look = follower.look(kAfterTheDay_s);
  expect_day_samples(look.samples, 1000, 2000);
  // Nothing changed: nothing read, nothing handed out.
  const std::size_t reads = follower.counts().file_reads;
  EXPECT_TRUE(follower.look(kAfterTheDay_s).samples.empty());
  EXPECT_EQ(follower.counts().file_reads, reads);
  // A replay's end (final): the cut line is dropped by the readers' rule, nothing handed out.
  look = follower.look(kAfterTheDay_s, true);
  EXPECT_TRUE(look.samples.empty());
  EXPECT_TRUE(any_warning_has(look.warnings, "last line dropped")) << (look.warnings.empty() ? "" : look.warnings[0]);
  EXPECT_EQ(follower.counts().samples, 2000u);
  EXPECT_EQ(follower.counts().lines_refused(), 0u);
  EXPECT_EQ(follower.state().newest_s, mic::test::wic_time_s(1999));
}

TEST(RecordFollower, AFileRewrittenWithMoreLinesGivesItsNewLinesOnce) {
  const std::string dir = mic::test::make_temp_dir("follower_rewritten");
  const std::string path = dir + "/wic20250514vsec.sec";
  mic::test::write_bytes(path, mic::test::iaga_text(mic::test::wic_lines(0, 5000)));
  mic::RecordFileFollower follower(follow(dir + "/*.sec"));
  expect_day_samples(follower.look(kAfterTheDay_s).samples, 0, 5000);
  replace_file(path, mic::test::iaga_text(mic::test::wic_lines(0, 9000)));  // a new inode
  expect_day_samples(follower.look(kAfterTheDay_s).samples, 5000, 9000);
  mic::test::write_bytes(path, mic::test::iaga_text(mic::test::wic_lines(0, 12000)));  // rewritten in place
  expect_day_samples(follower.look(kAfterTheDay_s).samples, 9000, 12000);
  // The same content again: read, nothing handed out, nothing refused.
  replace_file(path, mic::test::iaga_text(mic::test::wic_lines(0, 12000)));
  const std::size_t reads = follower.counts().file_reads;
  const mic::FollowerLook again = follower.look(kAfterTheDay_s);
  EXPECT_EQ(follower.counts().file_reads, reads + 1);
  EXPECT_TRUE(again.samples.empty());
  EXPECT_TRUE(again.warnings.empty()) << again.warnings.front();
  EXPECT_EQ(follower.counts().lines_refused(), 0u);
}

TEST(RecordFollower, FilesOfAnotherStationOrSamplePeriodAreRefusedAndNamed) {
  const std::string dir = mic::test::make_temp_dir("follower_strangers");
  mic::test::write_bytes(dir + "/wic_a.sec", mic::test::iaga_text(mic::test::wic_lines(0, 3600)));
  mic::test::write_bytes(dir + "/wic_b.sec", mic::test::iaga_text(mic::test::wic_lines(3600, 7200)));
  // Sorted first by name, of another station: the stream is still the most files' (WIC, 1 s).
  mic::test::write_bytes(dir + "/aaa_ngk.sec", mic::test::iaga_text(mic::test::wic_lines(0, 3600), "", "NGK"));
  mic::test::write_bytes(dir + "/wic_min.sec", mic::test::iaga_text(mic::test::wic_lines(0, 86400, 60)));
  mic::test::write_bytes(dir + "/.wic_c.sec.part", "not read");  // a download in progress
  mic::RecordFileFollower follower(follow(dir));
  const mic::FollowerLook look = follower.look(kAfterTheDay_s);
  expect_day_samples(look.samples, 0, 7200);
  EXPECT_EQ(follower.state().station, "WIC");
  EXPECT_EQ(follower.state().sample_period_s, 1.0);
  EXPECT_TRUE(any_warning_has(look.warnings, "file refused: " + dir + "/aaa_ngk.sec: station 'NGK', not the stream's 'WIC'"))
      << look.warnings.size();
  EXPECT_TRUE(any_warning_has(look.warnings, dir + "/wic_min.sec: sample period 60 s, not the stream's 1 s"));
  ASSERT_EQ(follower.files().size(), 4u);  // the hidden file is not a record
  EXPECT_NE(follower.files()[0].refused.find("station 'NGK'"), std::string::npos);
  EXPECT_EQ(follower.counts().refusals, 2u);
  // Another file that is not a record appears: refused, named, the rest followed.
  mic::test::write_bytes(dir + "/README.txt", "files of the remote observatory\n");
  mic::test::write_bytes(dir + "/wic_c.sec", mic::test::iaga_text(mic::test::wic_lines(7200, 7300)));
  const mic::FollowerLook later = follower.look(kAfterTheDay_s);
  expect_day_samples(later.samples, 7200, 7300);
  EXPECT_TRUE(any_warning_has(later.warnings, "file refused: " + dir + "/README.txt"));
  EXPECT_EQ(follower.counts().refusals, 3u);
  // Given station and period decide even when most files are others'.
  mic::RecordFollowerSettings given = follow(dir);
  given.station = "NGK";
  mic::RecordFileFollower ngk(given);
  expect_day_samples(ngk.look(kAfterTheDay_s).samples, 0, 3600);
}

TEST(RecordFollower, AStampStepBackIsRefusedAndCountedAForwardJumpLeavesAGap) {
  const std::string dir = mic::test::make_temp_dir("follower_clock");
  const std::string path = dir + "/wic.sec";
  // 0..999; the remote's clock steps back 100 s (records 1000..1099 stamped 900..999), then on;
  // at 1500 it jumps an hour ahead (records 1500..1599 stamped 5100..5199).
  std::vector<std::string> lines = mic::test::wic_lines(0, 1000);
  for (std::size_t k = 1000; k < 1100; ++k) lines.push_back(mic::test::wic_line_stamped(k, k - 100));
  for (const std::string& line : mic::test::wic_lines(1100, 1500)) lines.push_back(line);
  for (std::size_t k = 1500; k < 1600; ++k) lines.push_back(mic::test::wic_line_stamped(k, k + 3600));
  mic::test::write_bytes(path, mic::test::iaga_text(lines));
  mic::RecordFileFollower follower(follow(path));
  const mic::FollowerLook look = follower.look(kAfterTheDay_s);
  // Records 0..999, 1100..1499 at their own stamps, 1500..1599 an hour later (a gap of 3600 s).
  ASSERT_EQ(look.samples.size(), 1500u);
  for (std::size_t i = 0; i < look.samples.size(); ++i) {
    const std::size_t k = i < 1000 ? i : i + 100;
    ASSERT_EQ(look.samples.time_s[i], mic::test::wic_time_s(k < 1500 ? k : k + 3600)) << i;
    ASSERT_EQ(look.samples.values_nT.row(static_cast<Eigen::Index>(i)), whole_wic_day().values_nT.row(static_cast<Eigen::Index>(k)));
  }
  EXPECT_EQ(follower.counts().lines_backwards, 100u);
  EXPECT_TRUE(any_warning_has(look.warnings, path + ": 100 line(s) refused (100 stamped not after the line before, 0 ahead"));
  // Between looks the clock steps back again: new lines stamped before the newest handed out.
  std::string more;
  for (std::size_t k = 1600; k < 1650; ++k) more += mic::test::wic_line_stamped(k, k + 3500) + "\r\n";
  append_bytes(path, more);
  const mic::FollowerLook back = follower.look(kAfterTheDay_s);
  EXPECT_TRUE(back.samples.empty());
  EXPECT_EQ(follower.counts().lines_backwards, 150u);  // the file's lines 1600.. are behind its own line before
  // Stamps ahead of the clock are refused and do not block the lines after them.
  const std::string ahead_path = dir + "/ahead.sec";
  std::vector<std::string> ahead = mic::test::wic_lines(0, 100);
  ahead.push_back(mic::test::wic_line_stamped(100, 86000));
  for (const std::string& line : mic::test::wic_lines(101, 200)) ahead.push_back(line);
  mic::test::write_bytes(ahead_path, mic::test::iaga_text(ahead));
  mic::RecordFileFollower live(follow(ahead_path));
  const mic::FollowerLook now = live.look(mic::test::wic_time_s(200));  // the clock at record 200
  expect_day_samples(now.samples, 0, 200, {100});
  EXPECT_EQ(live.counts().lines_ahead, 1u);
}

TEST(RecordFollower, ARestartFromTheStateFilePublishesNoSampleTwiceAndNoneLost) {
  const std::string dir = mic::test::make_temp_dir("follower_restart");
  const std::string path = dir + "/wic.sec", state_path = dir + "/follower.state";
  mic::test::write_bytes(path, mic::test::iaga_text(mic::test::wic_lines(0, 43200)));  // half the day
  mic::RecordFollowerSettings s = follow(dir);
  s.ignored_path = state_path;
  mic::RecordFollowerState state;
  {
    mic::RecordFileFollower first(s);
    expect_day_samples(first.look(kAfterTheDay_s).samples, 0, 43200);
    mic::test::write_bytes(state_path, mic::follower_state_text(first.state()));
  }
  // While it is down the file grows; the state file sits in the followed directory.
  append_bytes(path, lines_text(mic::test::wic_lines(43200, 50000)));
  state = mic::read_follower_state(state_path);
  EXPECT_EQ(state.newest_s, mic::test::wic_time_s(43199));
  EXPECT_EQ(state.station, "WIC");
  mic::RecordFileFollower second(s, state);
  const mic::FollowerLook look = second.look(kAfterTheDay_s);
  expect_day_samples(look.samples, 43200, 50000);
  EXPECT_TRUE(look.warnings.empty()) << look.warnings.front();
  EXPECT_EQ(second.counts().lines_refused(), 0u);
  ASSERT_EQ(second.files().size(), 1u);
  // A file first seen after the start with samples already passed: refused and counted.
  mic::test::write_bytes(dir + "/late.sec", mic::test::iaga_text(mic::test::wic_lines(40000, 40010)));
  const mic::FollowerLook late = second.look(kAfterTheDay_s);
  EXPECT_TRUE(late.samples.empty());
  EXPECT_EQ(second.counts().not_after_newest, 10u);
  EXPECT_TRUE(any_warning_has(late.warnings, dir + "/late.sec: 10 sample(s) from 2025-05-14T11:06:40"));
}

TEST(RecordFollower, SeveralFilesADayAndAGapAreHandedOutInTimeOrder) {
  const std::string dir = mic::test::make_temp_dir("follower_hourly");
  mic::RecordFileFollower follower(follow(dir + "/wic_*.sec"));
  // Hour 0, its last line whole but without a line end: held while it may be written.
  mic::test::write_bytes(dir + "/wic_00.sec", mic::test::iaga_text(mic::test::wic_lines(0, 3599), mic::test::wic_day().data[3599]));
  expect_day_samples(follower.look(kAfterTheDay_s).samples, 0, 3599);
  // Hours 1 and 5 arrive together (a gap of 3 h), the later one named first: hour 0 is finished
  // (its last line read), then all in time order.
  mic::test::write_bytes(dir + "/wic_05.sec", mic::test::iaga_text(mic::test::wic_lines(18000, 21600)));
  mic::test::write_bytes(dir + "/wic_01.sec", mic::test::iaga_text(mic::test::wic_lines(3600, 7200)));
  std::rename((dir + "/wic_05.sec").c_str(), (dir + "/wic_0.sec").c_str());
  const mic::FollowerLook look = follower.look(kAfterTheDay_s);
  std::vector<std::size_t> gap;
  for (std::size_t k = 7200; k < 18000; ++k) gap.push_back(k);
  expect_day_samples(look.samples, 3599, 21600, gap);
  EXPECT_TRUE(look.warnings.empty()) << look.warnings.front();
  // The same hour again in another file (a copy in another name): nothing twice.
  mic::test::write_bytes(dir + "/wic_05_copy.sec", mic::test::iaga_text(mic::test::wic_lines(18000, 21700)));
  const mic::FollowerLook copy = follower.look(kAfterTheDay_s);
  expect_day_samples(copy.samples, 21600, 21700);
  EXPECT_EQ(follower.counts().not_after_newest, 3600u);
}

TEST(RecordFollower, TheStateFileReadsBackExactly) {
  mic::RecordFollowerState state;
  state.newest_s = 1747180800.123;
  state.station = "WIC";
  state.sample_period_s = 1.0;
  state.components = {"H", "E", "Z"};
  state.path = "/data/obs \"2\"/*.sec";
  const mic::RecordFollowerState back = mic::parse_follower_state(mic::follower_state_text(state), "state");
  EXPECT_EQ(back.newest_s, state.newest_s);
  EXPECT_EQ(back.station, state.station);
  EXPECT_EQ(back.sample_period_s, state.sample_period_s);
  EXPECT_EQ(back.components, state.components);
  EXPECT_EQ(back.path, state.path);
  EXPECT_EQ(mic::parse_follower_state(mic::follower_state_text(mic::RecordFollowerState()), "state").newest_s,
            -std::numeric_limits<double>::infinity());
  try {
    mic::parse_follower_state("station: WIC\n", "f.state");
    ADD_FAILURE() << "a state without its stamp was read";
  } catch (const mic::InputError& e) {
    EXPECT_STREQ(e.what(), "f.state: newest_published: missing");
  }
  EXPECT_THROW(mic::parse_follower_state("newest_published: soon\n", "f.state"), mic::InputError);
  const std::string dir = mic::test::make_temp_dir("follower_state");
  EXPECT_EQ(mic::read_follower_state(dir + "/none.state").newest_s, -std::numeric_limits<double>::infinity());
}
