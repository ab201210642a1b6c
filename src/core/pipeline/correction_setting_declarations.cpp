// correction_node's settings, each declared once (setting_declarations.hpp).
#include "magnetometer_insitu_calibration/pipeline/setting_declarations.hpp"

namespace magnetometer_insitu_calibration {

namespace {

using K = SettingKind;
constexpr const char* kNone = "";

SettingDeclarations topics() {
  return setting_group("Topics and file", {
      text_setting(K::kTopic, "test_topic", "test_topic", kNone, "", "the raw test sensor_msgs/MagneticField (T)")
          .made_required(),
      text_setting(K::kText, "test_name", "test_name", kNone, "",
                   "the test a calibration held at start must be for; \"\" = any"),
      text_setting(K::kTopic, "corrected_topic", "corrected_topic", kNone, "corrected",
                   "the corrected MagneticField (T, reference frame)"),
      text_setting(K::kTopic, "calibration_topic", "calibration_topic", kNone, "calibration",
                   "the MagnetometerCalibration to follow"),
      text_setting(K::kPath, "calibration_file", "calibration_file", kNone, "",
                   "YAML loaded at start (written by calibration_node); \"\" = none"),
      text_setting(K::kTopic, "temperature_topic", "temperature_topic", kNone, "",
                   "the test sensor's sensor_msgs/Temperature (degC): the calibration's temperature terms; \"\" = none"),
  });
}

SettingDeclarations correction() {
  return setting_group("Correction", {
      number_setting("reload_period", "reload_period", kNone, "s (wall)", 0.0, at_least(0),
                     "re-read calibration_file when it changed; 0 = only at start"),
      flag_setting("correct_samples_before_window", "correct_samples_before_window", kNone, true,
                   "samples stamped before the calibration's window: corrected with it (true) or dropped and counted"),
      flag_setting("check_frame_id", "check_frame_id", kNone, true,
                   "correct only samples whose frame_id is the calibration's test_frame_id"),
      flag_setting("include_calibration_covariance", "include_calibration_covariance", kNone, true,
                   "add n's uncertainty to the output covariance"),
      flag_setting("apply_offset", "apply_offset", kNone, true, "subtract the calibration's offset_nT before n^-T"),
      number_setting("max_matrix_condition", "max_matrix_condition", kNone, "-", 100.0, at_least(1),
                     "a calibration whose n is worse conditioned is refused"),
      number_setting("temperature_max_age", "temperature_max_age", kNone, "s", 10.0, above(0),
                     "largest stamp difference between a sample and the thermometer reading used"),
      choice_setting("temperature_model", "temperature_model", kNone, {"apparent", "full"}, "apparent",
                     "apparent: subtract a u (no scale term); full: offset and scale terms as fitted"),
  });
}

SettingDeclarations queues() {
  return setting_group("Queues and diagnostics", {
      integer_setting("queue_size", "queue_size", kNone, "messages", 10000, at_least(1), "the raw test topic's queue"),
      integer_setting("publisher_queue_size", "publisher_queue_size", kNone, "messages", 10000, at_least(1),
                      "the corrected topic's queue"),
      number_setting("diagnostic_period", "diagnostic_period", kNone, "s (ROS time)", 1.0, above(0),
                     "between /diagnostics"),
  });
}

}  // namespace

const SettingDeclarations& correction_setting_declarations() {
  static const SettingDeclarations declarations = joined_settings({topics(), correction(), queues()});
  return declarations;
}

}  // namespace magnetometer_insitu_calibration
