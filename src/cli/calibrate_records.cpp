// calibrate_records: in-situ calibration of a test magnetometer record against a reference
// record (IAGA-2002, CSV, plain or gzip; LEMI binary; MagPy CDF, ImagCDF; one or several files per
// instrument). Prints the table; --json writes the full report.
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_report.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_summary.hpp"
#include "magnetometer_insitu_calibration/pipeline/reference_noise.hpp"
#include "magnetometer_insitu_calibration/formats/record_join.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "magnetometer_insitu_calibration/formats/scalar_record.hpp"
#include "magnetometer_insitu_calibration/formats/tolerance_file.hpp"

#include "bag_input.hpp"  // --bag FILE --reference-topic T --test-topic T (src/program_support)

#include "command_line.hpp"  // parse_command_line: exit 1 on a usage error (src/program_support)

#include <CLI/CLI.hpp>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>

namespace mic = magnetometer_insitu_calibration;

namespace {

/// "0.0002:0.01" -> band edges in Hz.
void parse_band(const std::string& text, mic::EstimatorSettings& s) {
  const auto colon = text.find(':');
  try {
    if (colon == std::string::npos) throw std::invalid_argument("no colon");
    std::size_t used = 0;
    s.band_low_hz = std::stod(text.substr(0, colon), &used);
    if (used != colon) throw std::invalid_argument("trailing text");
    const std::string high = text.substr(colon + 1);
    s.band_high_hz = std::stod(high, &used);
    if (used != high.size()) throw std::invalid_argument("trailing text");
  } catch (const std::exception&) {
    throw mic::InputError("--band", "expected LOW:HIGH in Hz, e.g. 0.0002:0.01, got '" + text + "'");
  }
}

/// Paths as the report names them: several joined by " + ".
std::string joined(const std::vector<std::string>& paths) {
  std::string out;
  for (const std::string& p : paths) out += (out.empty() ? "" : " + ") + p;
  return out;
}

/// --help without the value CLI11 prints after a negated flag's name ("--screen,--no-screen{false}"
/// reads as "off by default" where the flag is on): the descriptions say the default.
class HelpFormatter : public CLI::Formatter {
 public:
  std::string make_option_name(const CLI::Option* option, bool positional) const override {
    std::string name = CLI::Formatter::make_option_name(option, positional);
    for (std::size_t at = name.find("{false}"); at != std::string::npos; at = name.find("{false}")) name.erase(at, 7);
    return name;
  }
};

/// The robust estimator's own steps (robust_estimator.hpp; docs/method.md), for studies of
/// what each step does; the defaults are the package's.
void add_robust_options(CLI::App& app, mic::RobustSettings& robust) {
  const char* group = "Robust estimator steps";
  app.add_flag("--screen,!--no-screen", robust.screen, "residual screen (step 1); on by default")->group(group);
  app.add_option("--screen-threshold", robust.screen_threshold, "screen threshold, robust sigmas")
      ->capture_default_str()->group(group);
  app.add_option("--screen-baseline", robust.screen_baseline_s, "screen's running-median baseline, s")
      ->capture_default_str()->group(group);
  app.add_option("--screen-margin", robust.screen_margin_s, "margin around a screened run, s")
      ->capture_default_str()->group(group);
  app.add_option("--section-length", robust.section_s, "section length, s (at least 2 / band low)")
      ->capture_default_str()->group(group);
  app.add_flag("--section-trend,!--no-section-trend", robust.section_trend, "Eq. 2's trend column in every section; on by default")
      ->group(group);
  app.add_option("--huber-k", robust.huber_k, "Huber constant of the cell weights, sigmas")
      ->capture_default_str()->group(group);
  app.add_option("--section-rejection", robust.section_rejection, "section level above which a section gets weight 0")
      ->capture_default_str()->group(group);
  app.add_option("--iterations", robust.iterations, "IRLS iterations at most")->capture_default_str()->group(group);
}


/// The command line's values that are not settings themselves.
struct Options {
  std::vector<std::string> reference_paths, test_paths, third_paths, remote_paths, scalar_paths;  // joined in time order
  std::string field_direction;  // "D,I" or "D,I,hdz", degrees
  std::string tolerance_file;   // the user's tolerances (tolerance_file.hpp); "": INTERMAGNET's
  std::string json_path, band = "0.0002:0.01", method = "robust", eiv = "given";
  bool no_trend = false, no_despike = false;
  double reference_noise_pT = 0.0;
  CLI::Option* model_option = nullptr;
  CLI::Option* intervals_option = nullptr;
};

/// Inputs, windows and pre-processing options.
void add_input_options(CLI::App& app, Options& o, mic::CalibrationSettings& settings,
                       std::unique_ptr<mic::BagInputOptions>& bag) {
  auto* reference_option = app.add_option("--reference", o.reference_paths,
                                          "reference record (IAGA-2002 or CSV, .gz allowed; LemiBin, LEMI compact "
                                          "flash, LEMI-025 byte stream; MagPy CDF, ImagCDF); several files (daily "
                                          "files) are joined in time order")
                               ->required();
  auto* test_option = app.add_option("--test", o.test_paths, "test record (same formats, one or several files)")->required();
  bag = std::make_unique<mic::BagInputOptions>(app, reference_option, test_option);  // or both from one bag
  auto* remote_option = app.add_option(
      "--remote", o.remote_paths,
      "a remote observatory's record (same formats, one or several files; any orientation and calibration): n "
      "from it as the instruments (remote reference), which local disturbances both sensors see do not bias");
  bag->add_remote_topic(app, remote_option);
  app.add_option("--scalar", o.scalar_paths,
                 "an absolute scalar magnetometer's F (MagPy CDF f, ImagCDF GeomagneticFieldF, IAGA-2002 F column, CSV "
                 "time,F; one or several files): the reference's scale along the main field, per window");
  app.add_option("--field-direction", o.field_direction,
                 "the main field's declination and inclination at the station, degrees, D,I (reference x north) or "
                 "D,I,hdz (reference x along H): the scalar check's per-axis scales");
  app.add_option("--tolerance-file", o.tolerance_file,
                 "YAML with the tolerances of the summary's verdicts (scale_percent, nonorthogonality_deg, "
                 "misalignment_deg; docs/programs.md); default INTERMAGNET's 1-second standard");
  auto* intervals = app.add_option("--intervals", settings.windows.intervals,
                                   "K >= 1 equal intervals, then the whole record (the paper's layout)");
  o.intervals_option = intervals;
  auto* window = app.add_option("--window", settings.windows.window_s, "sliding window length, s");
  auto* step = app.add_option("--step", settings.windows.step_s, "sliding window step, s");
  intervals->excludes(window)->excludes(step);
  window->needs(step);
  step->needs(window);
  app.add_option("--json", o.json_path, "write the full report as JSON to this file");
  app.add_option("--tolerance", settings.preprocess.pairing_tolerance_s, "largest stamp difference of a pair, s")
      ->capture_default_str();
  app.add_option("--output-period", settings.preprocess.output_period_s,
                 "estimation sample period, s (faster records are Gaussian-FIR decimated)")
      ->capture_default_str();
  app.add_flag("--no-despike", o.no_despike, "keep spikes");
  app.add_option("--max-fill", settings.window.gaps.max_fill_s,
                 "gaps longer than this (s) flag the windows that overlap them; shorter ones are bridged by "
                 "straight lines in both records (a window more than 5 % filled is flagged too)")
      ->capture_default_str();
  app.add_option("--temperature-channel", settings.preprocess.temperature_channel,
                 "the test record's sensor temperature: auto (sensor_temperature, a T_sensor channel, "
                 "temperature), none, or a channel name; fits nT/degC and ppm/degC terms when it varies")
      ->capture_default_str();
  app.add_option("--temperature-min-range", settings.window.temperature.min_range_C,
                 "peak-to-peak temperature (degC) in a window below which no temperature terms are fitted")
      ->capture_default_str();
}

/// The estimator's options.
void add_estimator_options(CLI::App& app, Options& o, mic::WindowCalibrationSettings& window_settings) {
  mic::EstimatorSettings& estimator = window_settings.estimator;
  app.add_option("--band", o.band, "estimation band LOW:HIGH, Hz")->capture_default_str();
  app.add_option("--gamma", estimator.gamma, "weight exponent: lambda_j^gamma")->capture_default_str();
  app.add_flag("--no-trend", o.no_trend, "no linear-trend column");
  app.add_option("--min-coherence", estimator.min_coherence, "quality rule")->capture_default_str();
  app.add_option("--max-condition", estimator.max_condition_number, "quality rule")->capture_default_str();
  app.add_option("--eiv", o.eiv,
                 "robust: errors-in-variables correction: given (for the reference's noise: its figure, "
                 "--reference-noise-pT, else identified from --third or from the pair above the band) or none")
      ->capture_default_str();
  auto* third_option = app.add_option(
      "--third", o.third_paths,
      "a third co-located instrument's record (same formats, one or several files), used only to identify the "
      "reference's noise by the three-cornered hat in each window");
  auto* noise_option = app.add_option("--reference-noise-pT", o.reference_noise_pT,
                 "robust, --eiv given: the reference's noise figure, pT/sqrt(Hz) at 1 Hz (maker's data "
                 "sheet; taken as 1/f noise below 1 Hz); 0: identified from the data")
      ->capture_default_str();
  third_option->excludes(noise_option);
  o.model_option = app.add_flag(
      "--response-model,!--no-response-model", window_settings.response_model,
      "fit a delay + 1-pole low-pass per component to the relative response and estimate n through a "
      "significant corner (on by default with --method robust; off with --method plain unless given)");
  app.add_flag("--pair-noise,!--no-pair-noise", window_settings.pair_noise,
               "robust, --eiv given, no figure and no --third: identify the reference's noise from the pair above "
               "the band (0.03-0.25 Hz at 1 s) and correct n for it (on by default); off: no correction");
  add_robust_options(app, estimator.robust);
  app.add_option("--method", o.method, "estimator: robust (default) or plain (Eq. 2 as printed)")->capture_default_str();
  app.add_flag("--auto-band", estimator.robust.auto_band,
               "choose the band from the coherence between the instruments (reported per window)");
}

/// An error naming a settings field (the core's settings name their fields) named by the option
/// the user gave instead; any other error (a file and line, an option) unchanged.
mic::InputError named_by_option(const mic::InputError& e) {
  static const std::map<std::string, std::string> options = {
      {"pairing_tolerance_s", "--tolerance"}, {"output_period_s", "--output-period"}, {"max_fill", "--max-fill"},
      {"band_low_hz", "--band"}, {"band_high_hz", "--band"}, {"window", "--window"}, {"step", "--step"},
      {"intervals", "--intervals"}, {"huber_k", "--huber-k"}, {"iterations", "--iterations"},
      {"section_rejection", "--section-rejection"}, {"section_s", "--section-length"},
      {"screen_threshold", "--screen-threshold"}, {"screen_margin_s", "--screen-margin"},
      {"screen_baseline_s", "--screen-baseline"}, {"gamma", "--gamma"}, {"min_coherence", "--min-coherence"},
      {"max_condition_number", "--max-condition"}, {"temperature_channel", "--temperature-channel"},
      {"temperature_min_range", "--temperature-min-range"}};
  return mic::renamed(e, options);
}

/// Refused before any work: the same file as reference and test (a record against itself gives
/// n = I with intervals of zero), and a JSON report that could not be written at the end.
void check_paths(const Options& o) {
  namespace fs = std::filesystem;
  std::error_code error;
  for (const std::string& r : o.reference_paths)
    for (const std::string& t : o.test_paths)
      if (fs::equivalent(r, t, error)) {
        throw mic::InputError("--test", "'" + t + "' is also given as --reference: a record against itself has "
                                        "nothing to calibrate");
      }
  if (!o.json_path.empty()) {
    const fs::path dir = fs::absolute(fs::path(o.json_path)).parent_path();
    if (!fs::is_directory(dir, error) || ::access(dir.c_str(), W_OK) != 0) {
      throw mic::InputError("--json", "cannot write '" + o.json_path + "': " + dir.string() +
                                          " is not a writable directory");
    }
  }
}

/// The parsed values into the settings; InputError naming the option for an impossible one.
void apply_options(const Options& o, mic::CalibrationSettings& settings) {
  mic::WindowCalibrationSettings& window_settings = settings.window;
  mic::EstimatorSettings& estimator = window_settings.estimator;
  parse_band(o.band, estimator);
  if (o.intervals_option->count() > 0 && settings.windows.intervals < 1) {
    throw mic::InputError("--intervals", "must be >= 1, got " + std::to_string(settings.windows.intervals) +
                                             " (for the whole record as one window, leave out --intervals, --window "
                                             "and --step)");
  }
  estimator.trend = !o.no_trend;
  settings.preprocess.despike = !o.no_despike;
  estimator.method = mic::parse_estimator_method(o.method, "--method");
  // --method plain is Eq. 2 as printed: no modelled filter unless asked for.
  if (estimator.method == mic::EstimatorMethod::kPlain && o.model_option->count() == 0) {
    window_settings.response_model = false;
  }
  if (o.eiv != "given" && o.eiv != "none") throw mic::InputError("--eiv", "expected given or none, got '" + o.eiv + "'");
  estimator.robust.errors_in_variables = o.eiv == "given";
  if (!(o.reference_noise_pT >= 0.0) || !std::isfinite(o.reference_noise_pT)) {
    throw mic::InputError("--reference-noise-pT", "must be a noise figure >= 0 pT/sqrt(Hz)");
  }
  window_settings.reference_noise_figure = mic::NoiseSpectrum::fluxgate_figure(o.reference_noise_pT);
  if (o.reference_noise_pT > 0.0 && !estimator.robust.errors_in_variables) {
    throw mic::InputError("--reference-noise-pT", "is used by --eiv given only (got --eiv " + o.eiv + ")");
  }
  if (!o.field_direction.empty()) {
    try {
      window_settings.field_direction = mic::parse_field_direction(o.field_direction);
    } catch (const std::invalid_argument& error) {
      throw mic::InputError("--field-direction", error.what());
    }
  }
  if (!o.tolerance_file.empty()) window_settings.tolerances = mic::read_tolerance_file(o.tolerance_file);
  if (!o.third_paths.empty() && !estimator.robust.errors_in_variables) {
    throw mic::InputError("--third", "identifies the noise for --eiv given only (got --eiv " + o.eiv + ")");
  }
  settings.validate();
}

/// Records of one or several files (read_records: joined in time order), warnings on stderr.
mic::VectorRecord read_side(const std::vector<std::string>& paths) {
  std::vector<std::string> warnings;
  mic::VectorRecord out = mic::read_records(paths, &warnings);
  mic::print_warnings("calibrate_records", warnings);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"In-situ calibration of a test magnetometer against a co-located reference (FD-WLSE, Eq. 2)."};
  app.formatter(std::make_shared<HelpFormatter>());
  Options o;
  mic::CalibrationSettings settings;
  std::unique_ptr<mic::BagInputOptions> bag;
  add_input_options(app, o, settings, bag);
  add_estimator_options(app, o, settings.window);
  if (const auto status = mic::parse_command_line(app, argc, argv)) return *status;

  bool any_ok = false;
  try {
    apply_options(o, settings);
    check_paths(o);
    const auto [reference, test] = bag->records(o.reference_paths, o.test_paths);
    mic::VectorRecord third, remote;
    mic::SideRecords sides;
    if (!o.third_paths.empty()) {
      third = read_side(o.third_paths);
      sides.third = &third;
    }
    if (!o.remote_paths.empty()) remote = read_side(o.remote_paths);
    if (!o.remote_paths.empty() || bag->remote(remote)) sides.remote = &remote;
    mic::ScalarRecord scalar;
    if (!o.scalar_paths.empty()) {
      scalar = mic::read_scalar_records(o.scalar_paths);
      sides.scalar = &scalar;
    }
    const mic::PairCalibration result = mic::calibrate_records(reference, test, settings, sides);
    for (const auto& w : result.windows) any_ok = any_ok || w.estimate.quality == mic::Quality::kOk;
    mic::ReportInputs inputs = bag->inputs(o.reference_paths, o.test_paths, reference, test);
    inputs.remote = bag->from_bag() ? bag->remote_input() : joined(o.remote_paths);
    std::cout << mic::format_calibration_summary(result, settings.window.tolerances)
              << mic::format_calibration_table(result, inputs);
    if (!o.json_path.empty()) {
      std::ofstream out(o.json_path);
      if (!out) throw mic::InputError(o.json_path, "cannot write the JSON report");
      out << mic::calibration_to_json(result, settings, inputs).dump(2) << "\n";
      if (!out) throw mic::InputError(o.json_path, "write failed");
    }
  } catch (const mic::InputError& e) {
    std::cerr << "calibrate_records: " << named_by_option(e).what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "calibrate_records: error: " << e.what() << "\n";
    return 1;
  }
  if (!any_ok) {  // the report is written; a script must not take it for a calibration
    std::cerr << "calibrate_records: every window is flagged (see the report): no calibration to apply\n";
    return 3;
  }
  return 0;
}
