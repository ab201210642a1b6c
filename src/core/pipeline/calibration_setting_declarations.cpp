// The calibration's settings, each declared once: calibration_node's parameter, calibrate_records'
// option, unit, default, range and help (setting_declarations.hpp). Keys are the core's field
// names as its checks name them.
#include "magnetometer_insitu_calibration/pipeline/setting_declarations.hpp"

namespace magnetometer_insitu_calibration {

namespace {

using K = SettingKind;
constexpr const char* kNone = "";

SettingDeclarations topics_and_files() {
  return setting_group("Topics and files", {
      text_setting(K::kTopic, "reference_topic", "reference_topic", kNone, "",
                   "the reference's sensor_msgs/MagneticField (T)").made_required(),
      text_setting(K::kTopic, "test_topic", "test_topic", kNone, "",
                   "the test's sensor_msgs/MagneticField (T); or give ~tests").made_required(),
      text_setting(K::kText, "test_name", "test_name", kNone, "test", "the test's label in messages, logs and the file"),
      text_setting(K::kTopic, "calibration_topic", "calibration_topic", kNone, "calibration",
                   "MagnetometerCalibration out, latched"),
      text_setting(K::kPath, "calibration_file", "calibration_file", kNone, "",
                   "YAML of the latest accepted calibration, resumed at start").made_required(),
      text_setting(K::kTopic, "temperature_topic", "temperature_topic", kNone, "",
                   "the test sensor's sensor_msgs/Temperature (degC): temperature terms; \"\" = none"),
      text_setting(K::kList, "tests", "tests", kNone, "",
                   "several tests instead of the five above: {name, topic, calibration_file, calibration_topic, "
                   "temperature_topic, input_period}")
          .noted("-"),
      text_setting(K::kTopic, "remote_topic", "remote_topic", kNone, "",
                   "a remote observatory's MagneticField (any frame): the remote reference; \"\" = none"),
      text_setting(K::kTopic, "scalar_topic", "scalar_topic", kNone, "",
                   "an absolute scalar magnetometer's ScalarField (T): the reference's scale check; \"\" = none"),
      text_setting(K::kText, "field_direction", "field_direction", "--field-direction", "",
                   "the main field's D,I (or D,I,hdz), degrees: the scalar check's per-axis scales; \"\" = none"),
      text_setting(K::kPath, "tolerance_file", "tolerance_file", "--tolerance-file", "",
                   "YAML of the verdicts' tolerances (scale_percent, nonorthogonality_deg, misalignment_deg)")
          .noted("INTERMAGNET 1-second"),
  });
}

SettingDeclarations sampling_and_pairing() {
  return setting_group("Sampling and pairing", {
      number_setting("input_period_s", "input_period", kNone, "s", 1.0, above(0),
                     "the reference's sample period (0.1 for a LEMI-025 at 10 Hz), and the others' unless given"),
      number_setting("test_input_period_s", "test_input_period", kNone, "s", 0.0, above(0),
                     "the tests' period when not the reference's: each stream filtered onto the epochs")
          .noted("input_period"),
      number_setting("remote_input_period_s", "remote_input_period", kNone, "s", 0.0, above(0),
                     "the remote's period when not the reference's (with remote_topic)")
          .noted("input_period"),
      flag_setting("stamps_apart", "stamps_apart", kNone, false,
                   "one rate, stamps at another phase: each stream filtered onto the epochs before pairing"),
      number_setting("output_period_s", "output_period", "--output-period", "s", 1.0, above(0),
                     "estimation period; faster inputs are Gaussian-FIR low-passed and decimated to it"),
      number_setting("sigma_s", "decimation_sigma", kNone, "s", 0.0, at_least(0),
                     "the decimation kernel's sigma; 0 = gain 0.01 at the output Nyquist (0.966 s at 1 s)"),
      number_setting("half_width_sigmas", "decimation_half_width", kNone, "sigmas", 4.0, above(0),
                     "the decimation kernel's half-width"),
      number_setting("pairing_tolerance_s", "pairing_tolerance", "--tolerance", "s", 0.010, at_least(0),
                     "largest stamp difference of a pair; below half the input period")
          .aliased({"tolerance_s"}),
      number_setting("pairing_max_wait_s", "pairing_max_wait", kNone, "s", 600.0, at_least(0),
                     "how long (in stamps) a sample waits for its partner before it is counted unpaired")
          .aliased({"max_wait_s"}),
      number_setting("remote_max_wait_s", "remote_max_wait", kNone, "s", 21600.0, at_least(0),
                     "how long (in the pair's stamps) past its end a window waits for a late remote; then it goes on "
                     "and says why"),
      flag_setting("despike", "despike", "--despike", true,
                   "remove spikes from each input at its own rate (running-median Hampel rule, 8 MADs)"),
      text_setting(K::kText, "temperature_channel", kNone, "--temperature-channel", "auto",
                   "the test record's sensor temperature: auto, none or a channel name"),
  });
}

SettingDeclarations windows_and_gaps() {
  return setting_group("Windows and gaps", {
      number_setting("window", "window", "--window", "s", 86400.0, above(0), "window length")
          .option_noted("none: the whole record"),
      number_setting("step", "step", "--step", "s", 3600.0, above(0), "between window starts, at most the window")
          .option_noted("none"),
      integer_setting("intervals", kNone, "--intervals", "-", 0, at_least(1),
                      "K equal intervals, then the whole record (the paper's layout)")
          .noted("none"),
      number_setting("max_filled_fraction", "max_filled_fraction", "--max-filled-fraction", "-", 0.05, between(0, 1),
                     "a window with more of its epochs filled or missing is flagged"),
      number_setting("max_fill", "max_fill", "--max-fill", "s", 3600.0, at_least(0),
                     "a longer gap flags the windows it touches; shorter ones are bridged by straight lines")
          .aliased({"max_fill_s"}),
      number_setting("temperature_min_range", "temperature_min_range", "--temperature-min-range", "degC", 0.05,
                     at_least(0), "a window whose temperature varies less is estimated without temperature terms"),
      number_setting("temperature_max_gap", "temperature_max_gap", "--temperature-max-gap", "s", 60.0, above(0),
                     "longest thermometer gap interpolated, and its hold at the window's edges")
          .noted("max(60, 2 estimation periods)")
          .option_noted("60"),
  });
}

SettingDeclarations estimator() {
  return setting_group("Estimator and quality rules", {
      number_setting("band_low_hz", "band_low", "--band", "Hz", 0.0002, above(0), "the band's lower edge"),
      number_setting("band_high_hz", "band_high", "--band", "Hz", 0.01, above(0),
                     "the band's upper edge, above band_low and below the Nyquist frequency"),
      number_setting("gamma", "gamma", "--gamma", "-", 1.0, between(0, 4), "weight exponent: lambda_j^gamma"),
      flag_setting("trend", "trend", "--trend", true, "a linear-trend column (drift of test against reference)"),
      integer_setting("min_harmonics", "min_harmonics", "--min-harmonics", "-", 16, at_least(5),
                      "fewer DFT harmonics in the band flag the window"),
      number_setting("max_condition_number", "max_condition_number", "--max-condition", "-", 1e4, above(1),
                     "a worse-conditioned reference block flags the window"),
      number_setting("min_coherence", "min_coherence", "--min-coherence", "-", 0.5, SettingRange{0, 1, false, true},
                     "a component of lower coherence flags the window"),
      choice_setting("method", "method", "--method", {"robust", "plain"}, "robust",
                     "robust: residual screen + sectioned M-estimation; plain: Eq. 2 as printed"),
      flag_setting("auto_band", "auto_band", "--auto-band", false,
                   "choose the band by coherence within 0.0001-0.05 Hz (reported per window)"),
      choice_setting("eiv", "eiv", "--eiv", {"given", "none"}, "given",
                     "errors-in-variables correction for the reference's noise: given (a noise model) or none"),
      number_setting("reference_noise_figure", "reference_noise_pT", "--reference-noise-pT", "pT/sqrt(Hz) at 1 Hz",
                     0.0, at_least(0), "the reference's noise figure (1/f below 1 Hz); 0 = identified from the data"),
      flag_setting("three_cornered_hat", "three_cornered_hat", kNone, true,
                   "with two or more tests: the reference's noise from the three-cornered hat in every window"),
      flag_setting("pair_noise", "pair_noise", "--pair-noise", true,
                   "where nothing else gives it: the reference's noise from the pair above the band"),
      flag_setting("estimate_delay", "estimate_delay", "--estimate-delay", true,
                   "estimate the test-minus-reference delay"),
      flag_setting("correct_delay", "correct_delay", "--correct-delay", true,
                   "remove a significant delay before fitting (robust; needs estimate_delay)"),
      flag_setting("response_model", "response_model", "--response-model", true,
                   "fit a delay + 1-pole low-pass per component; estimate n through a significant corner")
          .option_noted("true; false with --method plain"),
  });
}

SettingDeclarations robust_steps() {
  return setting_group("Robust estimator steps", {
      flag_setting("screen", "screen", "--screen", true, "residual screen: outliers of T - R n0 masked in both records"),
      number_setting("screen_threshold", "screen_threshold", "--screen-threshold", "sigmas", 6.0, above(0),
                     "robust sigmas of the high-passed residual beyond which a sample is masked"),
      number_setting("screen_baseline_s", "screen_baseline", "--screen-baseline", "s", 3600.0, above(0),
                     "running-median baseline removed before the screen"),
      number_setting("screen_margin_s", "screen_margin", "--screen-margin", "s", 30.0, at_least(0),
                     "a masked run is widened by this on each side"),
      number_setting("section_s", "section_length", "--section-length", "s", 10800.0, above(0),
                     "section length, raised to 2 / band_low when shorter"),
      flag_setting("section_trend", "section_trend", "--section-trend", true, "Eq. 2's trend column in every section"),
      number_setting("huber_k", "huber_k", "--huber-k", "sigmas", 2.0, above(0), "Huber constant of the cell weights"),
      number_setting("section_rejection", "section_rejection", "--section-rejection", "-", 4.0, above(2),
                     "a section whose residual level exceeds this many times the typical gets weight 0"),
      integer_setting("iterations", "iterations", "--iterations", "-", 8, between(1, 100), "IRLS iterations at most"),
  });
}

SettingDeclarations node_monitoring() {
  return setting_group("Change check, monitoring and TF", {
      number_setting("false_alarm_probability", "change_false_alarm_probability", kNone, "-", 0.001,
                     SettingRange{0, 0.5, true, true}, "a window against the accepted calibration: the test's level"),
      number_setting("scale_tolerance", "change_scale_tolerance", kNone, "-", 1e-4, at_least(0),
                     "a scale ratio must move more than this to be reported as changed"),
      number_setting("angle_tolerance_deg", "change_angle_tolerance", kNone, "deg", 0.005, at_least(0),
                     "or an angle more than this"),
      number_setting("silent_timeout", "silent_timeout", kNone, "s (ROS time)", 10.0, above(0),
                     "a topic without a message for longer is reported silent"),
      number_setting("time_jump_threshold", "time_jump_threshold", kNone, "s", 60.0, above(0),
                     "a stamp step this long is a time jump; above the slowest stream's period"),
      integer_setting("queue_size", "queue_size", kNone, "messages", 10000, at_least(1), "input topics' queues"),
      integer_setting("max_pending_windows", "max_pending_windows", kNone, "windows", 8, at_least(1),
                      "windows waiting for the estimator; beyond, the oldest is dropped and counted"),
      number_setting("diagnostic_period", "diagnostic_period", kNone, "s (ROS time)", 1.0, above(0),
                     "between /diagnostics"),
      flag_setting("publish_tf", "publish_tf", kNone, false,
                   "each accepted n's rotation on /tf_static, reference frame -> test frame"),
      text_setting(K::kText, "tf_child_frame_suffix", "tf_child_frame_suffix", kNone, "",
                   "appended to the test frame_id for the child frame; no spaces or '/'"),
  });
}

}  // namespace

const SettingDeclarations& calibration_setting_declarations() {
  static const SettingDeclarations declarations = joined_settings(
      {topics_and_files(), sampling_and_pairing(), windows_and_gaps(), estimator(), robust_steps(), node_monitoring()});
  return declarations;
}

}  // namespace magnetometer_insitu_calibration
