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
  app.add_option("--gamma", settings.estimator.gamma, "weight exponent: lambda_j^gamma")->capture_default_str();
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
  app.add_option("--max-fill", settings.preprocess.gaps.max_fill_s,
                 "gaps longer than this (s) flag the windows that overlap them")
      ->capture_default_str();
  app.add_option("--min-coherence", settings.estimator.min_coherence, "quality rule")->capture_default_str();
  app.add_option("--max-condition", settings.estimator.max_condition_number, "quality rule")->capture_default_str();
  std::string method = "robust", eiv = "given";
  double reference_noise_pT = 0.0;
  auto* eiv_option = app.add_option(
      "--eiv", eiv,
      "robust: errors-in-variables correction: given (the reference's identified noise, "
      "--reference-noise-pT; none when not given), none, or ratio (a share of the residual, --eiv-ratio)")
      ->capture_default_str();
  auto* ratio_option = app.add_option("--eiv-ratio", settings.estimator.robust.eiv_noise_ratio,
                                      "robust, --eiv ratio (implied when given alone): reference noise PSD / test "
                                      "noise PSD")
                           ->capture_default_str();
  auto* third_option = app.add_option(
      "--third", third_paths,
      "a third co-located instrument's record (same formats, one or several files), used only to identify the "
      "reference's noise by the three-cornered hat for --eiv given");
  auto* noise_option = app.add_option("--reference-noise-pT", reference_noise_pT,
                 "robust, --eiv given: the reference's noise figure, pT/sqrt(Hz) at 1 Hz (maker's data "
                 "sheet; taken as 1/f noise below 1 Hz); 0: not identified, no correction")
      ->capture_default_str();
  third_option->excludes(noise_option);
  auto* model_option = app.add_flag(
      "--response-model,!--no-response-model", settings.response_model,
      "fit a delay + 1-pole low-pass per component to the relative response and estimate n through a "
      "significant corner (default with --method robust; off with --method plain unless given)");
  app.add_flag("--pair-noise,!--no-pair-noise", settings.pair_noise,
               "robust, --eiv given, no figure and no --third: identify the reference's noise from the pair above "
               "the band (0.03-0.25 Hz at 1 s) and correct n for it (default); off: no correction");
  app.add_option("--temperature-channel", settings.preprocess.temperature_channel,
                 "the test record's sensor temperature: auto (sensor_temperature, a T_sensor channel, "
                 "temperature), none, or a channel name; fits nT/degC and ppm/degC terms when it varies")
      ->capture_default_str();
  app.add_option("--temperature-min-range", settings.temperature.min_range_C,
                 "peak-to-peak temperature (degC) in a window below which no temperature terms are fitted")
      ->capture_default_str();
  app.add_option("--method", method, "estimator: robust (default) or plain (Eq. 2 as printed)")->capture_default_str();
  app.add_flag("--auto-band", settings.estimator.robust.auto_band,
               "choose the band from the coherence between the instruments (reported per window)");
  CLI11_PARSE(app, argc, argv);

  try {
    parse_band(band, settings.estimator);
    settings.estimator.trend = !no_trend;
    settings.preprocess.despike = !no_despike;
    settings.estimator.method = mic::parse_estimator_method(method, "--method");
    // --method plain is Eq. 2 as printed: no modelled filter unless asked for.
    if (settings.estimator.method == mic::EstimatorMethod::kPlain && model_option->count() == 0) {
      settings.response_model = false;
    }
    // --eiv-ratio alone keeps meaning what it meant: the ratio mode, asked for explicitly.
    if (ratio_option->count() > 0 && eiv_option->count() == 0) eiv = "ratio";
    settings.estimator.robust.eiv = mic::parse_eiv_correction(eiv, "--eiv");
    if (!(reference_noise_pT >= 0.0) || !std::isfinite(reference_noise_pT)) {
      throw mic::InputError("--reference-noise-pT", "must be a noise figure >= 0 pT/sqrt(Hz)");
    }
    if (reference_noise_pT > 0.0 && settings.estimator.robust.eiv != mic::EivCorrection::kGiven) {
      throw mic::InputError("--reference-noise-pT", "is used by --eiv given only (got --eiv " + eiv + ")");
    }
    settings.estimator.robust.reference_pink_nT_per_sqrt_hz.setConstant(reference_noise_pT / 1000.0);
    if (!third_paths.empty() && settings.estimator.robust.eiv != mic::EivCorrection::kGiven) {
      throw mic::InputError("--third", "identifies the noise for --eiv given only (got --eiv " + eiv + ")");
    }
    settings.validate();
    const auto [reference, test] = bag.records(reference_paths, test_paths);
    // calibrate_records() in two steps, so that --third uses the pair as prepared.
    mic::PairCalibration result;
    const mic::PreparedPair prepared = mic::prepare_pair(reference, test, settings.preprocess, &result.report);
    if (!third_paths.empty()) {
      std::vector<std::string> warnings;
      const mic::VectorRecord third = mic::read_records(third_paths, &warnings);
      for (const std::string& w : warnings) std::cerr << "warning: " << w << "\n";
      const mic::IdentifiedNoise noise =
          mic::identify_reference_noise(prepared, reference, third, settings.preprocess, settings.estimator.band_low_hz,
                                        settings.estimator.band_high_hz);
      std::cout << noise.text << "\n";
      settings.estimator = mic::with_identified_noise(settings.estimator, noise, "three-cornered hat with --third");
    }
    result.windows = mic::calibrate_prepared(prepared, settings);
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
