// export_corrected: the test record corrected into the reference frame with an in-situ
// calibration, written as IAGA-2002 (70-column records, the 12 mandatory header records,
// comments stating the calibration applied: matrix, window, source), or as ImagCDF 1.2 when the
// output name ends in .cdf (the same statements in the global attribute Comments; temperature
// channels of a CDF input as Temperature<n>).
//
//   export_corrected --test TEST --calibration report.json [--window "whole record"] --output out.sec
//   export_corrected --bag pair.bag --test-topic /test/magnetic_field --calibration fge.yaml --output out.sec
//
// Correction (rows are samples, nT; T = R n): r = t n^-1. The calibration is one window of a
// calibrate_records --json report, or the YAML file of calibration_node (the latest accepted
// window). Only n is applied: n is estimated without harmonic 0, and the offset d the report
// gives beside it (the test against the reference at the window's end, what correction_node
// removes live) is not removed here: an archive keeps the observatory's baselines, so an offset
// b of the test reading appears in the output as b n^-1 and the corrected series takes its own
// baselines from absolute measurements, as any variometer record. The trend column is not
// applied either.
#include "archive_records.hpp"

#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/formats/record_join.hpp"
#include "magnetometer_insitu_calibration/formats/imagcdf_writer.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "bag_records.hpp"  // src/program_support
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include "command_line.hpp"  // parse_command_line: exit 1 on a usage error (src/program_support)

#include <CLI/CLI.hpp>

#include <array>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>

namespace mic = magnetometer_insitu_calibration;

namespace {

/// The calibration applied and the words that describe it.
struct Applied {
  Eigen::Matrix3d n = Eigen::Matrix3d::Identity();
  std::string window;        ///< "whole record 2025-05-14T00:00:00.000Z to ..."
  std::string quality;       ///< "ok", ...
  std::string inputs;        ///< "reference X, test Y"
  std::string parameters;    ///< scale ratios, non-orthogonality
  /// The test record's components n was estimated on (a JSON report's preprocessing), empty when
  /// the calibration does not say (a YAML file, an earlier report).
  std::vector<std::string> test_components;
  /// The reference's files as the report names them (settings.reference_files; in an older
  /// report, settings.reference split at " + ").
  std::vector<std::string> reference_files;
  /// The test stream's frame_id n was estimated on: a node's calibration file, or a report made
  /// from a bag (preprocessing.test_frame_id); empty when the calibration does not say.
  std::string test_frame_id;
};

std::string fixed(double v, int decimals) {
  char b[48];
  std::snprintf(b, sizeof b, "%.*f", decimals, v);
  return b;
}

Applied from_json(const std::string& path, const std::string& which) {
  const nlohmann::json report = mic::read_json_file(path);
  const mic::ReportWindow w = mic::select_report_window(report, which, path);
  Applied a;
  a.n = w.n;
  a.window = "'" + w.label + "' (" + w.start + " to " + w.end + ")";
  a.quality = w.quality;
  if (report.contains("settings")) {
    const nlohmann::json& s = report["settings"];
    a.inputs = "reference " + s.value("reference", std::string("?")) + ", test " + s.value("test", std::string("?"));
    const bool listed = s.contains("reference_files") && s["reference_files"].is_array();
    if (listed) {
      for (const nlohmann::json& f : s["reference_files"]) a.reference_files.push_back(f.get<std::string>());
    }
    const std::string files = listed ? std::string() : s.value("reference", std::string());
    for (std::size_t first = 0; first < files.size();) {
      const std::size_t plus = files.find(" + ", first);
      a.reference_files.push_back(files.substr(first, plus == std::string::npos ? std::string::npos : plus - first));
      first = plus == std::string::npos ? files.size() : plus + 3;
    }
  }
  if (report.contains("preprocessing") && report["preprocessing"].contains("test_components") &&
      report["preprocessing"]["test_components"].is_array()) {
    for (const nlohmann::json& c : report["preprocessing"]["test_components"]) a.test_components.push_back(c.get<std::string>());
  }
  if (report.contains("preprocessing") && report["preprocessing"].contains("test_frame_id") &&
      report["preprocessing"]["test_frame_id"].is_string()) {
    a.test_frame_id = report["preprocessing"]["test_frame_id"].get<std::string>();
  }
  const nlohmann::json& j = w.json;
  try {
    std::ostringstream p;
    p << "Scale ratios Kt/Kr x y z: " << fixed(j["scale_ratio"][0], 6) << " " << fixed(j["scale_ratio"][1], 6) << " "
      << fixed(j["scale_ratio"][2], 6) << "; non-orthogonality xy xz yz: " << fixed(j["nonorthogonality_deg"]["xy"], 4)
      << " " << fixed(j["nonorthogonality_deg"]["xz"], 4) << " " << fixed(j["nonorthogonality_deg"]["yz"], 4)
      << " deg; misalignment x y z: " << fixed(j["misalignment_deg"][0], 4) << " " << fixed(j["misalignment_deg"][1], 4)
      << " " << fixed(j["misalignment_deg"][2], 4) << " deg.";
    a.parameters = p.str();
  } catch (const std::exception&) {
    a.parameters.clear();  // a null (not finite) value: the matrix says it all
  }
  return a;
}

Applied from_yaml(const std::string& path) {
  mic::MagnetometerCalibration c;
  try {
    c = mic::load_calibration_file(path);
  } catch (const mic::CalibrationFileError& e) {
    throw mic::InputError(path, e.what());
  }
  Applied a;
  for (int r = 0; r < 3; ++r) {
    for (int col = 0; col < 3; ++col) a.n(r, col) = c.matrix[static_cast<std::size_t>(3 * r + col)];
  }
  a.window = "'" + c.test_name + "' live window (" + mic::format_iso8601(c.window_start.toSec(), 3) + " to " +
             mic::format_iso8601(c.window_end.toSec(), 3) + ")";
  a.quality = c.accepted ? "ok" : "not accepted: " + c.quality_text;
  a.inputs = "reference frame " + c.reference_frame_id + ", test frame " + c.test_frame_id;
  a.test_frame_id = c.test_frame_id;
  a.parameters = "Scale ratios Kt/Kr x y z: " + fixed(c.scale_ratio[0], 6) + " " + fixed(c.scale_ratio[1], 6) + " " +
                 fixed(c.scale_ratio[2], 6) + "; non-orthogonality xy xz yz: " +
                 fixed(c.nonorthogonality_deg[0], 4) + " " + fixed(c.nonorthogonality_deg[1], 4) + " " +
                 fixed(c.nonorthogonality_deg[2], 4) + " deg.";
  return a;
}

std::string upper(std::string text) {
  for (char& c : text) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return text;
}

/// Refuses a record whose components are not those n was estimated on (letter case aside): n
/// maps the calibrated axes, and a record of another orientation (H, D, Z against X, Y, Z) or
/// another instrument would be corrected into nonsense without a word. Records from bags are not
/// checked: a MagneticField names no components.
void check_components(const Applied& applied, const mic::VectorRecord& record, const std::string& record_name,
                      const std::string& calibration_path) {
  if (applied.test_components.empty()) return;
  std::string calibrated, recorded;
  bool same = applied.test_components.size() == 3;
  for (std::size_t k = 0; k < 3; ++k) {
    const std::string c = k < applied.test_components.size() ? applied.test_components[k] : std::string("?");
    calibrated += (k ? "," : "") + c;
    recorded += (k ? "," : "") + record.components[k];
    same = same && upper(c) == upper(record.components[k]);
  }
  if (!same) {
    throw mic::InputError(record_name, "components " + recorded + ", but " + calibration_path +
                                           " was estimated on a test record of components " + calibrated +
                                           ": its n maps those axes, not these (another orientation or instrument?)");
  }
}

/// Refuses a bag's test topic whose frame_id is not the one n was estimated on (a MagneticField's
/// instrument identity, the frame its x, y, z are axes of). Not checked when either is unknown.
void check_frame(const Applied& applied, const mic::VectorRecord& record, const std::string& calibration_path) {
  const std::string frame = mic::bag_frame_id(record);
  if (applied.test_frame_id.empty() || frame.empty()) return;
  if (frame != applied.test_frame_id) {
    throw mic::InputError(record.source, "frame_id '" + frame + "', but " + calibration_path +
                                             " was estimated on a test stream of frame_id '" + applied.test_frame_id +
                                             "': its n maps that instrument's axes, not these (another --test-topic?)");
  }
}

/// Refuses a test file that is one of the reference files the report was estimated with: n
/// corrects the test instrument, and applied to the reference it writes a plausible-looking
/// record of nothing. A report file that no longer resolves from here is not compared.
void check_not_reference(const Applied& applied, const std::vector<std::string>& test_paths,
                         const std::string& calibration_path) {
  std::error_code error;
  for (const std::string& t : test_paths)
    for (const std::string& r : applied.reference_files)
      if (std::filesystem::equivalent(t, r, error)) {
        throw mic::InputError(t, "is the reference " + calibration_path +
                                     " was estimated against, not its test: n corrects the test instrument");
      }
}

bool ends_with(const std::string& text, const std::string& suffix) {
  return text.size() >= suffix.size() && text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::array<std::string, 3> split_components(const std::string& text) {
  std::array<std::string, 3> out;
  std::stringstream stream(text);
  std::string item;
  std::size_t k = 0;
  while (std::getline(stream, item, ',')) {
    if (k >= 3 || item.empty()) break;
    out[k++] = item;
  }
  if (k != 3 || std::getline(stream, item, ',')) {
    throw mic::InputError("--components", "expected three names separated by commas, e.g. H,E,Z; got '" + text + "'");
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Test magnetometer record corrected into the reference frame (r = t n^-1), written as IAGA-2002."};
  std::vector<std::string> test_paths;  // several files (daily files): joined in time order
  std::string bag_path, test_topic, calibration_path, which, output, components;
  mic::Iaga2002WriteOptions iaga;
  double max_condition = 100.0;
  bool allow_flagged = false;
  auto* test = app.add_option("--test", test_paths,
                              "test record: IAGA-2002, CSV (.gz allowed), LemiBin, LEMI compact flash, LEMI-025 stream, "
                              "MagPy CDF, ImagCDF; several files are joined in time order");
  auto* bag = app.add_option("--bag", bag_path, "rosbag holding the test record as sensor_msgs/MagneticField");
  auto* topic = app.add_option("--test-topic", test_topic, "test topic in --bag");
  bag->excludes(test)->needs(topic);
  topic->needs(bag);
  app.add_option("--calibration", calibration_path,
                 "calibrate_records --json report (.json) or calibration_node YAML file (.yaml/.yml)")
      ->required();
  app.add_option("--window", which,
                 "window of the JSON report: 1-based index or label (default: 'whole record', else the last ok window)");
  app.add_option("-o,--output", output, "IAGA-2002 file to write (.gz: compressed), or ImagCDF 1.2 if it ends in .cdf")
      ->required();
  app.add_option("--components", components, "names of the corrected components, e.g. H,E,Z (default: the test's)");
  app.add_option("--iaga-code", iaga.iaga_code, "IAGA code (default: the test record's)");
  app.add_option("--station-name", iaga.station_name, "Station Name");
  app.add_option("--source-of-data", iaga.source_of_data, "Source of Data");
  app.add_option("--latitude", iaga.geodetic_latitude, "Geodetic Latitude, degrees north");
  app.add_option("--longitude", iaga.geodetic_longitude, "Geodetic Longitude, degrees east (0..360)");
  app.add_option("--elevation", iaga.elevation, "Elevation, m");
  app.add_option("--digital-sampling", iaga.digital_sampling, "Digital Sampling, e.g. '0.1 second'");
  app.add_option("--data-type", iaga.data_type, "Data Type (default: the test record's, else variation)");
  app.add_option("--max-condition", max_condition, "refuse a matrix n with a larger condition number")
      ->capture_default_str();
  app.add_flag("--allow-flagged", allow_flagged, "apply a window whose quality is not ok");
  if (const auto status = mic::parse_command_line(app, argc, argv)) return *status;

  try {
    if (test_paths.empty() && bag_path.empty()) throw mic::InputError("--test", "is required (or --bag with --test-topic)");
    const bool yaml = ends_with(calibration_path, ".yaml") || ends_with(calibration_path, ".yml");
    if (yaml && !which.empty()) throw mic::InputError("--window", "applies to a JSON report, not to a YAML calibration");
    const Applied applied = yaml ? from_yaml(calibration_path) : from_json(calibration_path, which);
    if (applied.quality != "ok" && !allow_flagged) {
      throw mic::InputError(calibration_path, "window " + applied.window + " has quality '" + applied.quality +
                                                  "': not applied (--allow-flagged to apply it anyway)");
    }

    if (bag_path.empty()) check_not_reference(applied, test_paths, calibration_path);
    mic::VectorRecord record;
    std::string test_name;
    for (const std::string& p : test_paths) test_name += (test_name.empty() ? "" : " + ") + p;
    if (!bag_path.empty()) {
      record = mic::read_bag_records(bag_path, {test_topic}).front();
      test_name = record.source;
    } else {
      // The strict reader of calibrate_records: a damaged line refuses the record, naming file,
      // line and column, before any output is written (one rule for bad input in every program).
      std::vector<std::string> warnings;
      record = mic::read_records(test_paths, &warnings);
      mic::print_warnings("export_corrected", warnings);
    }
    if (bag_path.empty()) check_components(applied, record, test_name, calibration_path);  // a bag names none
    else check_frame(applied, record, calibration_path);  // a file names no frame
    const std::array<std::string, 3> names = components.empty() ? record.components : split_components(components);
    const mic::VectorRecord corrected = mic::correct_record(record, applied.n, names, max_condition);

    std::string letters;
    for (const std::string& c : names) letters += c;
    if (iaga.reported.empty()) iaga.reported = letters + "F";
    if (iaga.sensor_orientation.empty()) iaga.sensor_orientation = letters;
    char row[3][96];
    for (int r = 0; r < 3; ++r) {
      std::snprintf(row[r], sizeof row[r], "n row %d: %+.10f %+.10f %+.10f", r + 1, applied.n(r, 0), applied.n(r, 1),
                    applied.n(r, 2));
    }
    iaga.comments = {
        "Test record corrected into the reference frame by in-situ calibration against a co-located reference "
        "(FD-WLSE, Marusenkov et al.): r = t n^-1, rows are samples in nT, T = R n.",
        std::string(row[0]) + "\n" + row[1] + "\n" + row[2],
        "Calibration window " + applied.window + ", quality " + applied.quality + ", from " + calibration_path +
            (applied.inputs.empty() ? std::string() : " (" + applied.inputs + ")") + ".",
        "Test record: " + test_name + ".",
        "Baseline: only n applied; the offset d against the reference (report, correction_node) not removed: "
        "an offset b appears as b n^-1. Trend not removed. Derive baselines from absolute measurements.",
    };
    if (!applied.parameters.empty()) iaga.comments.insert(iaga.comments.begin() + 2, applied.parameters);
    if (const auto it = record.header.find("comments"); it != record.header.end() && !it->second.empty()) {
      iaga.comments.push_back("Comments of the test record:\n" + it->second);
    }
    if (ends_with(output, ".cdf")) {
      mic::ImagCdfWriteOptions cdf;
      cdf.iaga_code = iaga.iaga_code;
      cdf.observatory_name = iaga.station_name;
      cdf.institution = iaga.source_of_data;
      cdf.vector_sens_orient = iaga.sensor_orientation;
      cdf.comments = iaga.comments;
      const std::pair<const std::string*, double*> numbers[] = {
          {&iaga.geodetic_latitude, &cdf.latitude}, {&iaga.geodetic_longitude, &cdf.longitude}, {&iaga.elevation, &cdf.elevation}};
      for (const auto& [text, value] : numbers) {
        if (text->empty()) continue;
        try {
          *value = std::stod(*text);
        } catch (const std::exception&) {
          throw mic::InputError("--latitude/--longitude/--elevation", "not a number: '" + *text + "'");
        }
      }
      mic::write_imagcdf(output, corrected, cdf);
    } else {
      mic::write_iaga2002(output, corrected, iaga);
    }
    std::cout << "wrote " << output << ": " << corrected.size() << " samples of " << test_name
              << " corrected with window " << applied.window << "\n";
  } catch (const mic::InputError& e) {
    std::cerr << "export_corrected: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "export_corrected: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
