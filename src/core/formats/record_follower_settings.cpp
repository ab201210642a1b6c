// record_file_follower's settings, each declared once (record_follower_settings.hpp).
#include "magnetometer_insitu_calibration/formats/record_follower_settings.hpp"

namespace magnetometer_insitu_calibration {

namespace {

using K = SettingKind;
constexpr const char* kNone = "";

SettingDeclarations files() {
  return setting_group("Files", {
      text_setting(K::kPath, "path", "path", kNone, "",
                   "a directory (every file in it) or a glob pattern of the remote's record files, any format the "
                   "package reads")
          .made_required(),
      text_setting(K::kText, "station", "station", kNone, "",
                   "the remote's station: a file of another is refused; \"\" = the files' own (most files of the "
                   "first look)"),
      number_setting("sample_period", "sample_period", kNone, "s", 0.0, at_least(0),
                     "the remote's sample period: a file of another is refused; 0 = the files' own"),
      text_setting(K::kPath, "state_file", "state_file", kNone, "",
                   "the newest stamp published, written atomically: a restart publishes the samples after it; \"\" = "
                   "none"),
      text_setting(K::kText, "start", "start", kNone, "",
                   "without a stamp in the state file: the first stamp to publish, ISO 8601 UTC; \"\" = the files' "
                   "first"),
      number_setting("ahead_tolerance", "ahead_tolerance", kNone, "s", 300.0, at_least(0),
                     "a stamp later than the wall clock plus this is refused (a remote clock stepped ahead)"),
  });
}

SettingDeclarations publishing() {
  return setting_group("Publishing", {
      text_setting(K::kTopic, "topic", "topic", kNone, "magnetic_field", "the sensor_msgs/MagneticField out (T)"),
      text_setting(K::kText, "frame_id", "frame_id", kNone, "remote",
                   "header.frame_id: the remote's sensor axes, x, y, z = the files' three columns (e.g. H, E, Z)"),
      number_setting("noise_nT", "noise_nT", kNone, "nT", 0.0, at_least(0),
                     "per-sample noise, the covariance's diagonal; 0 = covariance unknown"),
      flag_setting("follow", "follow", kNone, true,
                   "look for new files and lines every poll_period (true), or publish the files present once and "
                   "stop (false: a replay)"),
      number_setting("poll_period", "poll_period", kNone, "s (wall)", 10.0, above(0), "between looks at the files"),
      number_setting("rate", "rate", kNone, "-", 1000.0, at_least(0),
                     "publishing speed against the stamps: 1 = real time, 0 = as fast as possible"),
      integer_setting("wait_for_subscribers", "wait_for_subscribers", kNone, "subscribers", 1, at_least(0),
                      "publishing waits while the topic has fewer subscribers; 0 = never"),
      integer_setting("publisher_queue_size", "publisher_queue_size", kNone, "messages", 10000, at_least(1),
                      "the topic's queue"),
  });
}

SettingDeclarations diagnostics() {
  return setting_group("Diagnostics", {
      number_setting("max_lag", "max_lag", kNone, "s (wall)", 21600.0, at_least(0),
                     "following: WARN when the newest stamp published is older than this; 0 = no check"),
      number_setting("diagnostic_period", "diagnostic_period", kNone, "s (wall)", 1.0, above(0),
                     "between /diagnostics"),
  });
}

}  // namespace

const SettingDeclarations& record_file_follower_setting_declarations() {
  static const SettingDeclarations declarations = joined_settings({files(), publishing(), diagnostics()});
  return declarations;
}

}  // namespace magnetometer_insitu_calibration
