// calibrate_records: in-situ calibration of a test magnetometer record against a reference
// record (IAGA-2002, CSV, plain or gzip; LEMI binary; MagPy CDF, ImagCDF; one or several files per
// instrument). Prints the table; --json writes the full report.
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_report.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_summary.hpp"
#include "magnetometer_insitu_calibration/pipeline/reference_noise.hpp"
#include "magnetometer_insitu_calibration/pipeline/setting_declarations.hpp"
#include "magnetometer_insitu_calibration/formats/record_join.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "magnetometer_insitu_calibration/formats/scalar_record.hpp"
#include "magnetometer_insitu_calibration/formats/tolerance_file.hpp"

#include "bag_input.hpp"  // --bag FILE --reference-topic T --test-topic T (src/program_support)

#include "command_line.hpp"     // parse_command_line: exit 1 on a usage error (src/program_support)
#include "setting_options.hpp"  // the declared settings as options (src/program_support)

#include <CLI/CLI.hpp>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

namespace mic = magnetometer_insitu_calibration;

namespace {

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

using Settings = mic::CalibrationSettings;

/// The declared settings calibrate_records reads into CalibrationSettings
/// (pipeline/setting_declarations.hpp; docs/programs.md's table is printed from them), and the
/// tolerance file read into the verdicts' tolerances.
const mic::SettingBindings<Settings>& program_bindings() {
  static const mic::SettingBindings<Settings> bindings = [] {
    mic::SettingBindings<Settings> b = mic::calibration_settings_bindings();
    b.bind_with(
        "tolerance_file",
        [](Settings& s, const mic::SettingValue& v) {
          s.window.tolerances = mic::read_tolerance_file(std::get<std::string>(v));
        },
        [](const Settings&) { return mic::SettingValue(std::string()); });
    return b;
  }();
  return bindings;
}

/// The command line's inputs and outputs (records are measured inputs, not settings).
struct Options {
  std::vector<std::string> reference_paths, test_paths, third_paths, remote_paths, scalar_paths;  // joined in time order
  std::string json_path;
};

/// Inputs and the report.
void add_input_options(CLI::App& app, Options& o, std::unique_ptr<mic::BagInputOptions>& bag) {
  const char* group = "Records and report";
  auto* reference_option = app.add_option("--reference", o.reference_paths,
                                          "reference record (IAGA-2002 or CSV, .gz allowed; LemiBin, LEMI compact "
                                          "flash, LEMI-025 byte stream; MagPy CDF, ImagCDF); several files (daily "
                                          "files) are joined in time order")
                               ->required()
                               ->group(group);
  auto* test_option = app.add_option("--test", o.test_paths, "test record (same formats, one or several files)")
                          ->required()
                          ->group(group);
  bag = std::make_unique<mic::BagInputOptions>(app, reference_option, test_option);  // or both from one bag
  auto* remote_option = app.add_option(
      "--remote", o.remote_paths,
      "a remote observatory's record (same formats, one or several files; any orientation and calibration): n "
      "from it as the instruments (remote reference), which local disturbances both sensors see do not bias")
      ->group(group);
  bag->add_remote_topic(app, remote_option);
  app.add_option("--scalar", o.scalar_paths,
                 "an absolute scalar magnetometer's F (MagPy CDF f, ImagCDF GeomagneticFieldF, IAGA-2002 F column, CSV "
                 "time,F; one or several files): the reference's scale along the main field, per window")
      ->group(group);
  app.add_option("--third", o.third_paths,
                 "a third co-located instrument's record (same formats, one or several files), used only to identify "
                 "the reference's noise by the three-cornered hat in each window")
      ->group(group);
  app.add_option("--json", o.json_path, "write the full report as JSON to this file")->group(group);
}

/// The rules between options: one window layout, the figure or the hat.
void relate_options(CLI::App& app) {
  CLI::Option* intervals = app.get_option("--intervals");
  CLI::Option* window = app.get_option("--window");
  CLI::Option* step = app.get_option("--step");
  intervals->excludes(window)->excludes(step);
  window->needs(step);
  step->needs(window);
  app.get_option("--third")->excludes(app.get_option("--reference-noise-pT"));
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
void apply_options(const Options& o, const mic::SettingOptions<Settings>& options, Settings& settings) {
  options.apply(settings);
  mic::WindowCalibrationSettings& window_settings = settings.window;
  // --method plain is Eq. 2 as printed: no modelled filter unless asked for.
  if (window_settings.estimator.method == mic::EstimatorMethod::kPlain && !options.given("response_model")) {
    window_settings.response_model = false;
  }
  const bool eiv = window_settings.estimator.robust.errors_in_variables;
  if (window_settings.reference_noise_figure.any() && !eiv) {
    throw mic::InputError("--reference-noise-pT", "is used by --eiv given only (got --eiv none)");
  }
  if (!o.third_paths.empty() && !eiv) {
    throw mic::InputError("--third", "identifies the noise for --eiv given only (got --eiv none)");
  }
  try {
    settings.validate();
  } catch (const mic::InputError& e) {
    throw options.named_by_option(e);
  }
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
  Settings settings;
  std::unique_ptr<mic::BagInputOptions> bag;
  add_input_options(app, o, bag);
  const mic::SettingOptions<Settings> options(app, program_bindings());
  relate_options(app);
  if (const auto status = mic::parse_command_line(app, argc, argv)) return *status;

  bool any_ok = false;
  try {
    apply_options(o, options, settings);
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
    std::cerr << "calibrate_records: " << options.named_by_option(e).what() << "\n";
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
