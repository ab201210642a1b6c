// calibrate_records: in-situ calibration of a test magnetometer record against a reference
// record (IAGA-2002, CSV, plain or gzip; LEMI binary; MagPy CDF, ImagCDF; one or several files per
// instrument). Prints the table; --json writes the full report.
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_report.hpp"
#include "magnetometer_insitu_calibration/pipeline/reference_noise.hpp"
#include "magnetometer_insitu_calibration/formats/record_join.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"

#include "bag_input.hpp"  // --bag FILE --reference-topic T --test-topic T (src/tools, tools.cmake)

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>

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

/// The robust estimator's own steps (robust_estimator.hpp; docs/method.md), for studies of
/// what each step does; the defaults are the package's.
void add_robust_options(CLI::App& app, mic::RobustSettings& robust) {
  const char* group = "Robust estimator steps";
  app.add_flag("--screen,!--no-screen", robust.screen, "residual screen (step 1)")->group(group);
  app.add_option("--screen-threshold", robust.screen_threshold, "screen threshold, robust sigmas")
      ->capture_default_str()->group(group);
  app.add_option("--screen-baseline", robust.screen_baseline_s, "screen's running-median baseline, s")
      ->capture_default_str()->group(group);
  app.add_option("--screen-margin", robust.screen_margin_s, "margin around a screened run, s")
      ->capture_default_str()->group(group);
  app.add_option("--section-length", robust.section_s, "section length, s (at least 2 / band low)")
      ->capture_default_str()->group(group);
  app.add_flag("--section-trend,!--no-section-trend", robust.section_trend, "Eq. 2's trend column in every section")
      ->group(group);
  app.add_option("--huber-k", robust.huber_k, "Huber constant of the cell weights, sigmas")
      ->capture_default_str()->group(group);
  app.add_option("--section-rejection", robust.section_rejection, "section level above which a section gets weight 0")
      ->capture_default_str()->group(group);
  app.add_option("--iterations", robust.iterations, "IRLS iterations at most")->capture_default_str()->group(group);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"In-situ calibration of a test magnetometer against a co-located reference (FD-WLSE, Eq. 2)."};
  std::vector<std::string> reference_paths, test_paths, third_paths;  // several files: joined in time order
  std::string json_path, band = "0.0002:0.01";
  mic::CalibrationSettings settings;
  bool no_trend = false, no_despike = false;
  auto* reference_option = app.add_option("--reference", reference_paths,
                                          "reference record (IAGA-2002 or CSV, .gz allowed; LemiBin, LEMI compact "
                                          "flash, LEMI-025 byte stream; MagPy CDF, ImagCDF); several files (daily "
                                          "files) are joined in time order")
                               ->required();
  auto* test_option = app.add_option("--test", test_paths, "test record (same formats, one or several files)")->required();
  mic::BagInputOptions bag(app, reference_option, test_option);  // or both records from one bag
  app.add_option("--band", band, "estimation band LOW:HIGH, Hz")->capture_default_str();
  mic::WindowCalibrationSettings& window_settings = settings.window;
  mic::EstimatorSettings& estimator = window_settings.estimator;
  app.add_option("--gamma", estimator.gamma, "weight exponent: lambda_j^gamma")->capture_default_str();
  app.add_flag("--no-trend", no_trend, "no linear-trend column");
  auto* intervals = app.add_option("--intervals", settings.windows.intervals,
                                   "K equal intervals, then the whole record (the paper's layout)");
  auto* window = app.add_option("--window", settings.windows.window_s, "sliding window length, s");
  auto* step = app.add_option("--step", settings.windows.step_s, "sliding window step, s");
  intervals->excludes(window)->excludes(step);
  window->needs(step);
  step->needs(window);
  app.add_option("--json", json_path, "write the full report as JSON to this file");
  app.add_option("--tolerance", settings.preprocess.pairing_tolerance_s, "largest stamp difference of a pair, s")
      ->capture_default_str();
  app.add_option("--output-period", settings.preprocess.output_period_s,
                 "estimation sample period, s (faster records are Gaussian-FIR decimated)")
      ->capture_default_str();
  app.add_flag("--no-despike", no_despike, "keep spikes");
  app.add_option("--max-fill", window_settings.gaps.max_fill_s,
                 "gaps longer than this (s) flag the windows that overlap them")
      ->capture_default_str();
  app.add_option("--min-coherence", estimator.min_coherence, "quality rule")->capture_default_str();
  app.add_option("--max-condition", estimator.max_condition_number, "quality rule")->capture_default_str();
  std::string method = "robust", eiv = "given";
  app.add_option("--eiv", eiv,
                 "robust: errors-in-variables correction: given (for the reference's noise: its figure, "
                 "--reference-noise-pT, else identified from --third or from the pair above the band) or none")
      ->capture_default_str();
  auto* third_option = app.add_option(
      "--third", third_paths,
      "a third co-located instrument's record (same formats, one or several files), used only to identify the "
      "reference's noise by the three-cornered hat in each window");
  double reference_noise_pT = 0.0;
  auto* noise_option = app.add_option("--reference-noise-pT", reference_noise_pT,
                 "robust, --eiv given: the reference's noise figure, pT/sqrt(Hz) at 1 Hz (maker's data "
                 "sheet; taken as 1/f noise below 1 Hz); 0: identified from the data")
      ->capture_default_str();
  third_option->excludes(noise_option);
  auto* model_option = app.add_flag(
      "--response-model,!--no-response-model", window_settings.response_model,
      "fit a delay + 1-pole low-pass per component to the relative response and estimate n through a "
      "significant corner (default with --method robust; off with --method plain unless given)");
  app.add_flag("--pair-noise,!--no-pair-noise", window_settings.pair_noise,
               "robust, --eiv given, no figure and no --third: identify the reference's noise from the pair above "
               "the band (0.03-0.25 Hz at 1 s) and correct n for it (default); off: no correction");
  add_robust_options(app, estimator.robust);
  app.add_option("--temperature-channel", settings.preprocess.temperature_channel,
                 "the test record's sensor temperature: auto (sensor_temperature, a T_sensor channel, "
                 "temperature), none, or a channel name; fits nT/degC and ppm/degC terms when it varies")
      ->capture_default_str();
  app.add_option("--temperature-min-range", window_settings.temperature.min_range_C,
                 "peak-to-peak temperature (degC) in a window below which no temperature terms are fitted")
      ->capture_default_str();
  app.add_option("--method", method, "estimator: robust (default) or plain (Eq. 2 as printed)")->capture_default_str();
  app.add_flag("--auto-band", estimator.robust.auto_band,
               "choose the band from the coherence between the instruments (reported per window)");
  CLI11_PARSE(app, argc, argv);

  try {
    parse_band(band, estimator);
    estimator.trend = !no_trend;
    settings.preprocess.despike = !no_despike;
    estimator.method = mic::parse_estimator_method(method, "--method");
    // --method plain is Eq. 2 as printed: no modelled filter unless asked for.
    if (estimator.method == mic::EstimatorMethod::kPlain && model_option->count() == 0) {
      window_settings.response_model = false;
    }
    if (eiv != "given" && eiv != "none") throw mic::InputError("--eiv", "expected given or none, got '" + eiv + "'");
    estimator.robust.errors_in_variables = eiv == "given";
    if (!(reference_noise_pT >= 0.0) || !std::isfinite(reference_noise_pT)) {
      throw mic::InputError("--reference-noise-pT", "must be a noise figure >= 0 pT/sqrt(Hz)");
    }
    window_settings.reference_noise_figure = mic::NoiseSpectrum::fluxgate_figure(reference_noise_pT);
    if (reference_noise_pT > 0.0 && !estimator.robust.errors_in_variables) {
      throw mic::InputError("--reference-noise-pT", "is used by --eiv given only (got --eiv " + eiv + ")");
    }
    if (!third_paths.empty() && !estimator.robust.errors_in_variables) {
      throw mic::InputError("--third", "identifies the noise for --eiv given only (got --eiv " + eiv + ")");
    }
    settings.validate();
    const auto [reference, test] = bag.records(reference_paths, test_paths);
    mic::VectorRecord third;
    if (!third_paths.empty()) {
      std::vector<std::string> warnings;
      third = mic::read_records(third_paths, &warnings);
      for (const std::string& w : warnings) std::cerr << "warning: " << w << "\n";
    }
    const mic::PairCalibration result =
        mic::calibrate_records(reference, test, settings, third_paths.empty() ? nullptr : &third);
    const mic::ReportInputs inputs = bag.inputs(reference_paths, test_paths);
    std::cout << mic::format_calibration_table(result, inputs);
    if (!json_path.empty()) {
      std::ofstream out(json_path);
      if (!out) throw mic::InputError(json_path, "cannot write the JSON report");
      out << mic::calibration_to_json(result, settings, inputs).dump(2) << "\n";
      if (!out) throw mic::InputError(json_path, "write failed");
    }
  } catch (const mic::InputError& e) {
    std::cerr << "calibrate_records: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "calibrate_records: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
