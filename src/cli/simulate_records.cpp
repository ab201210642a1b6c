// simulate_records: writes a simulated reference record, a simulated test record (IAGA-2002 or
// CSV) and truth.json (n_true row-major, trends, the settings) for testing the calibration.
//   simulate_records --out-dir DIR [--format iaga|csv] [--days D] [--rate HZ] [--seed S] ...
#include "magnetometer_insitu_calibration/formats/csv_record.hpp"
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "magnetometer_insitu_calibration/simulation/station_disturbances.hpp"
#include "magnetometer_insitu_calibration/simulation/hut_temperature.hpp"
#include "magnetometer_insitu_calibration/simulation/disturbance_classes.hpp"
#include "magnetometer_insitu_calibration/simulation/remote_observatory.hpp"
#include "magnetometer_insitu_calibration/simulation/scalar_magnetometer.hpp"
#include "magnetometer_insitu_calibration/simulation/unmodelled_disturbances.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include "command_line.hpp"  // parse_command_line: exit 1 on a usage error (src/program_support)

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

/// Strict number: the whole text must be one finite number.
double parse_number(const std::string& text, const std::string& option) {
  std::size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || !std::isfinite(value)) {
    throw mic::InputError(option, "expected a number, got '" + text + "'");
  }
  return value;
}

/// "a,b,c" (or "a,b" for count 2) -> numbers.
std::vector<double> parse_list(const std::string& text, std::size_t count, const std::string& option) {
  std::vector<double> values;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) values.push_back(parse_number(item, option));
  if (!text.empty() && text.back() == ',') values.push_back(NAN);  // "1,2," is malformed
  if (values.size() != count) {
    throw mic::InputError(option, "expected " + std::to_string(count) +
                                      " comma-separated numbers, got '" + text + "'");
  }
  return values;
}

Eigen::Vector3d parse_vector(const std::string& text, const std::string& option) {
  const std::vector<double> v = parse_list(text, 3, option);
  return Eigen::Vector3d(v[0], v[1], v[2]);
}

/// The options of the settings' fields (InputError::where() of their validate()): the
/// simulation's, the station disturbances' and the unmodelled disturbances'.
const std::map<std::string, std::string> kFieldOptions = {
    {"sample_period_s", "--rate"}, {"duration_s", "--days"}, {"start_time_s", "--start"},
    {"scale_ratio", "--scale"}, {"nonorthogonality_deg", "--nonorthogonality-deg"},
    {"misalignment_deg", "--misalignment-deg"}, {"reference_white_nT", "--noise-nT"}, {"test_white_nT", "--noise-nT"},
    {"reference_pink_nT_per_sqrt_hz", "--pink-nT"}, {"test_pink_nT_per_sqrt_hz", "--pink-nT"},
    {"drift_nT_per_day", "--drift-nT-per-day"}, {"tilt_rate_deg_per_day", "--tilt-deg-per-day"},
    {"tilt_axis", "--tilt-axis"}, {"delay_s", "--delay-s"}, {"spikes_per_day", "--spikes-per-day"},
    {"spike_amplitude_nT", "--spike-nT"}, {"gap_count", "--gaps"}, {"gap_length_s", "--gap-seconds"},
    {"variation_rms_nT", "--variation-rms-nT"}, {"spectral_index", "--spectral-index"},
    {"daily_amplitude_nT", "--daily-nT"}, {"variation_z_ratio", "--z-ratio"},
    {"vehicles_per_day", "--vehicles-per-day"}, {"road_distance_m", "--road-distance-m"},
    {"parking_probability", "--parking-probability"}, {"test_corner_hz", "--test-corner-hz"},
    {"test_delay_s", "--test-delay-s"}, {"tilt_walk_nT_per_sqrt_day", "--pier-tilt-walk-nT"},
    {"heater_nT", "--heater-nT"}, {"heater_period_s", "--heater-period-s"},
};

/// The command line: the simulation's settings (filled by CLI11 where an option maps to one
/// field) and the texts parsed after it.
struct Options {
  Options() {
    s.keep_clean_field = false;
    hut.daily_amplitude_C = hut.heater_amplitude_C = 0.0;  // no hut unless asked for
  }
  bool with_hut() const { return hut.daily_amplitude_C > 0.0 || hut.heater_amplitude_C > 0.0; }

  std::string out_dir, format = "iaga", start, scale, nonorth, misalign, noise = "0.01,0.01",
                       pink = "0.005,0.005", drift = "0,0,0", tilt_axis = "0,1,0",
                       spike_instrument = "either", gap_instrument = "either", daily;
  double days = 1.0, rate_hz = 1.0;
  int decimals = 4;
  mic::SimulationSettings s;
  // Disturbances of a disturbed station (station_disturbances.hpp), none by default.
  mic::StationDisturbanceSettings station;
  // What reaches the test instrument only and the estimators do not model (unmodelled_disturbances.hpp).
  mic::UnmodelledDisturbanceSettings unmodelled;
  std::string heater = "0,0,0";
  std::string disturbance_class;  // --disturbance-class (disturbance_classes.hpp)
  // A field hut: the test sensor's temperature and its coefficients (hut_temperature.hpp).
  mic::HutTemperatureSettings hut;
  std::string temperature_offset = "0.2,-0.15,0.3", temperature_scale = "15,-10,25";
  // A remote observatory beside the pair (remote_observatory.hpp): remote.<ext>.
  bool remote = false;
  mic::RemoteObservatorySettings remote_settings;
  std::string remote_z_incoherent;  // --remote-z-incoherent; empty: --remote-incoherent's
  // An absolute scalar magnetometer (scalar_magnetometer.hpp): scalar.csv; the reference's scale.
  bool scalar = false;
  mic::ScalarMagnetometerSettings scalar_settings;
  double reference_scale = 1.0;
};

/// Options of the record, the instruments' transfer and noise, and the field's variations.
void add_record_options(CLI::App& app, Options& o) {
  mic::SimulationSettings& s = o.s;
  app.add_option("--out-dir", o.out_dir, "output directory (created if missing)")->required();
  app.add_option("--format", o.format, "record format: iaga (IAGA-2002) or csv")->capture_default_str();
  app.add_option("--days", o.days, "record length, days")->capture_default_str();
  app.add_option("--rate", o.rate_hz, "sample rate, Hz (1 or 10 typically)")->capture_default_str();
  app.add_option("--seed", s.seed, "random seed")->capture_default_str();
  app.add_option("--start", o.start, "UTC start, ISO 8601 (default 2025-05-14T00:00:00Z)");
  app.add_option("--scale", o.scale, "scale-factor ratios K_test/K_ref x,y,z (default 0.9996,1.0004,1.0004)");
  app.add_option("--nonorthogonality-deg", o.nonorth, "xy,xz,yz: 90 deg minus angle between test axes (default 0.01,0,0.02)");
  app.add_option("--misalignment-deg", o.misalign, "rotation vector of reference->test rotation, deg (default 0.05,-0.1,0.3)");
  app.add_option("--noise-nT", o.noise, "white noise rms per sample, nT: reference,test")->capture_default_str();
  app.add_option("--pink-nT", o.pink, "1/f noise ASD at 1 Hz, nT/sqrt(Hz): reference,test")->capture_default_str();
  app.add_option("--drift-nT-per-day", o.drift, "linear drift of the test, nT/day, x,y,z")->capture_default_str();
  app.add_option("--tilt-deg-per-day", s.tilt_rate_deg_per_day, "tilt drift rate of the test axes, deg/day")->capture_default_str();
  app.add_option("--tilt-axis", o.tilt_axis, "tilt rotation axis, reference frame x,y,z")->capture_default_str();
  app.add_option("--spikes-per-day", s.spikes_per_day, "spikes per day (count rounded)")->capture_default_str();
  app.add_option("--spike-nT", s.spike_amplitude_nT, "spike size, nT")->capture_default_str();
  app.add_option("--spike-instrument", o.spike_instrument, "reference|test|either|both")->capture_default_str();
  app.add_option("--gaps", s.gap_count, "number of gaps (NaN runs)")->capture_default_str();
  app.add_option("--gap-seconds", s.gap_length_s, "length of each gap, s")->capture_default_str();
  app.add_option("--gap-instrument", o.gap_instrument, "reference|test|either|both")->capture_default_str();
  app.add_option("--delay-s", s.delay_s, "delay of the test instrument, s (fractional allowed)")->capture_default_str();
  app.add_option("--variation-rms-nT", s.variation_rms_nT, "rms of x,y power-law variations, nT")->capture_default_str();
  app.add_option("--spectral-index", s.spectral_index, "variations' PSD ~ f^-index")->capture_default_str();
  app.add_option("--daily-nT", o.daily, "24 h harmonic amplitude x,y,z, nT (default 20,10,10)");
  app.add_option("--z-ratio", s.variation_z_ratio, "rms of z variations / rms of x,y (weak Z: 0.2)")->capture_default_str();
}

/// Options of the station's disturbances (traffic) and of what reaches the test alone (pier
/// tilt, heater, filter mismatch).
void add_disturbance_options(CLI::App& app, Options& o) {
  mic::StationDisturbanceSettings& station = o.station;
  mic::UnmodelledDisturbanceSettings& unmodelled = o.unmodelled;
  app.add_option("--vehicles-per-day", station.vehicles_per_day,
                 "traffic: vehicles (magnetic dipoles) per day on a road, seen by the two sensors with "
                 "different gains and directions")->capture_default_str();
  app.add_option("--road-distance-m", station.road_distance_m, "traffic: road distance from the reference sensor, m")
      ->capture_default_str();
  app.add_option("--parking-probability", station.parking_probability, "traffic: share of vehicles that park by the road")
      ->capture_default_str();
  app.add_option("--pier-tilt-walk-nT", unmodelled.tilt_walk_nT_per_sqrt_day,
                 "random-walk tilt of the test pier: field change |B| theta after one day, nT/sqrt(day), "
                 "1 sigma per horizontal axis (0.27: about 0.6 nT over 5 days)")->capture_default_str();
  app.add_option("--heater-nT", o.heater, "heater cycling in the test sensor: field while on, test frame x,y,z, nT")
      ->capture_default_str();
  app.add_option("--heater-period-s", unmodelled.heater_period_s, "heater: mean on/off cycle, s (+-20 %, on 40 %)")
      ->capture_default_str();
  app.add_option("--disturbance-class", o.disturbance_class,
                 "a station of the disturbance family (disturbance_classes.hpp), set after the other options");
  app.add_option("--test-corner-hz", unmodelled.test_corner_hz,
                 "filter mismatch: one-pole low-pass of the test instrument, corner Hz (0: none)")->capture_default_str();
  app.add_option("--test-delay-s", unmodelled.test_delay_s,
                 "filter mismatch: extra delay of the test instrument after the low-pass, s")->capture_default_str();
}

/// Options of the field hut (the test's temperature and its coefficients) and the CSV's decimals.
/// Options of a remote observatory's record (remote.<iaga|csv>, station RMT).
void add_remote_options(CLI::App& app, Options& o) {
  app.add_flag("--remote", o.remote, "also write remote.<ext>: a remote observatory that sees the field but none of "
                                     "the local disturbances (its own axes, Z response and noise)");
  app.add_option("--remote-incoherent", o.remote_settings.incoherent_fraction,
                 "remote: share of its variations' variance that is its own, [0, 1)")->capture_default_str();
  app.add_option("--remote-z-incoherent", o.remote_z_incoherent,
                 "remote: the same for its vertical alone, [0, 1) (default: --remote-incoherent's; Z is the more "
                 "local component, often less coherent between stations)");
  app.add_option("--remote-coherence-corner-hz", o.remote_settings.coherence_corner_hz,
                 "remote: frequency at which its own share has risen to 1 - (1 - incoherent) / e, Hz (inf: the same "
                 "share at every frequency)")->capture_default_str();
  app.add_option("--remote-gaps", o.remote_settings.gap_count, "remote: number of its own gaps")->capture_default_str();
  app.add_option("--remote-time-offset-s", o.remote_settings.time_offset_s,
                 "remote: its stamps minus the true times, s (a wrong time base)")->capture_default_str();
  app.add_flag("--scalar", o.scalar, "also write scalar.csv (time,F): an absolute scalar magnetometer, F = |B| + noise");
  app.add_option("--scalar-period-s", o.scalar_settings.period_s, "scalar: between samples, s")->capture_default_str();
  app.add_option("--scalar-offset-s", o.scalar_settings.offset_s, "scalar: first stamp after the start, s (off whole seconds)")
      ->capture_default_str();
  app.add_option("--reference-scale", o.reference_scale,
                 "the reference reads this times the field (1.003: 0.3 % high), for the scalar check")->capture_default_str();
}

void add_hut_and_format_options(CLI::App& app, Options& o) {
  mic::HutTemperatureSettings& hut = o.hut;
  app.add_option("--hut-daily-C", hut.daily_amplitude_C, "hut: amplitude of the daily temperature cycle, degC (0: no hut)")
      ->capture_default_str();
  app.add_option("--hut-heater-C", hut.heater_amplitude_C, "hut: heater cycling, half peak-to-peak, degC (0: none)")
      ->capture_default_str();
  app.add_option("--hut-heater-period-s", hut.heater_period_s, "hut: mean heater cycle, s (+-20 %)")->capture_default_str();
  app.add_option("--temperature-offset-nT-per-C", o.temperature_offset, "hut: test offset coefficients x,y,z, nT/degC")
      ->capture_default_str();
  app.add_option("--temperature-scale-ppm-per-C", o.temperature_scale, "hut: test scale coefficients x,y,z, ppm/degC")
      ->capture_default_str();
  app.add_option("--decimals", o.decimals, "CSV value decimals (IAGA-2002 always has 2)")->capture_default_str();
}

/// Checks the record's options and parses the texts into the settings; throws InputError
/// naming the option.
void read_texts(Options& o) {
  mic::SimulationSettings& s = o.s;
  if (o.format != "iaga" && o.format != "csv") {
    throw mic::InputError("--format", "expected iaga or csv, got '" + o.format + "'");
  }
  if (!(o.days > 0.0) || !std::isfinite(o.days)) throw mic::InputError("--days", "must be positive");
  if (!(o.rate_hz > 0.0) || !std::isfinite(o.rate_hz)) throw mic::InputError("--rate", "must be positive");
  if (o.decimals < 0 || o.decimals > 17) throw mic::InputError("--decimals", "must be 0..17");
  s.duration_s = o.days * 86400.0;
  s.sample_period_s = 1.0 / o.rate_hz;
  if (!o.start.empty()) {
    try {
      s.start_time_s = mic::parse_iso8601(o.start);
    } catch (const std::exception& e) {
      throw mic::InputError("--start", e.what());
    }
  }
  if (!o.scale.empty()) s.scale_ratio = parse_vector(o.scale, "--scale");
  if (!o.nonorth.empty()) s.nonorthogonality_deg = parse_vector(o.nonorth, "--nonorthogonality-deg");
  if (!o.misalign.empty()) s.misalignment_deg = parse_vector(o.misalign, "--misalignment-deg");
  if (!o.daily.empty()) s.daily_amplitude_nT = parse_vector(o.daily, "--daily-nT");
  const std::vector<double> white = parse_list(o.noise, 2, "--noise-nT");
  s.reference_white_nT = white[0];
  s.test_white_nT = white[1];
  const std::vector<double> pink_levels = parse_list(o.pink, 2, "--pink-nT");
  s.reference_pink_nT_per_sqrt_hz = pink_levels[0];
  s.test_pink_nT_per_sqrt_hz = pink_levels[1];
  s.drift_nT_per_day = parse_vector(o.drift, "--drift-nT-per-day");
  s.tilt_axis = parse_vector(o.tilt_axis, "--tilt-axis");
  s.spike_instrument = mic::parse_simulated_instrument(o.spike_instrument, "--spike-instrument");
  s.gap_instrument = mic::parse_simulated_instrument(o.gap_instrument, "--gap-instrument");
  o.unmodelled.heater_nT = parse_vector(o.heater, "--heater-nT");
  o.station.seed = o.unmodelled.seed = o.hut.seed = s.seed;
  o.hut.offset_nT_per_C = parse_vector(o.temperature_offset, "--temperature-offset-nT-per-C");
  o.hut.scale_ppm_per_C = parse_vector(o.temperature_scale, "--temperature-scale-ppm-per-C");
  o.remote_settings.z_incoherent_fraction = o.remote_z_incoherent.empty()
                                                ? o.remote_settings.incoherent_fraction
                                                : parse_number(o.remote_z_incoherent, "--remote-z-incoherent");
  if (o.disturbance_class.empty()) return;
  mic::DisturbanceClassSettings c{s, o.station, o.unmodelled};
  mic::apply_disturbance_class(o.disturbance_class, s.seed, o.days, c);
  s = c.simulation;
  o.station = c.station;
  o.unmodelled = c.unmodelled;
}

/// Validates the settings; the InputError names the option of the field at fault.
void validate(const Options& o) {
  if (o.with_hut() && o.format != "csv") {
    throw mic::InputError("--format", "a hut (--hut-daily-C, --hut-heater-C) needs csv: IAGA-2002 has no temperature column");
  }
  try {
    o.s.validate();
    o.station.validate();
    o.unmodelled.validate();
  } catch (const mic::InputError& e) {
    throw mic::renamed(e, kFieldOptions);
  }
  try {
    o.hut.validate();
  } catch (const mic::InputError& e) {  // the hut's fields have their own options
    static const std::map<std::string, std::string> hut_options = {
        {"daily_amplitude_C", "--hut-daily-C"}, {"heater_amplitude_C", "--hut-heater-C"},
        {"heater_period_s", "--hut-heater-period-s"}, {"offset_nT_per_C", "--temperature-offset-nT-per-C"},
        {"scale_ppm_per_C", "--temperature-scale-ppm-per-C"}};
    throw mic::renamed(e, hut_options);
  }
  try {
    o.remote_settings.validate();
  } catch (const mic::InputError& e) {  // so are the remote's
    static const std::map<std::string, std::string> remote_options = {
        {"incoherent_fraction", "--remote-incoherent"}, {"z_incoherent_fraction", "--remote-z-incoherent"},
        {"coherence_corner_hz", "--remote-coherence-corner-hz"}, {"gap_count", "--remote-gaps"},
        {"time_offset_s", "--remote-time-offset-s"}};
    throw mic::renamed(e, remote_options);
  }
}

std::filesystem::path make_out_dir(const std::string& out_dir) {
  std::error_code error;
  std::filesystem::create_directories(out_dir, error);
  if (error || !std::filesystem::is_directory(out_dir)) {
    throw mic::InputError("--out-dir", "cannot create directory '" + out_dir + "': " + error.message());
  }
  return std::filesystem::path(out_dir);
}

/// The pair with every asked-for disturbance; with a hut, test.csv gets a sensor_temperature column.
mic::SimulatedPair simulate(const Options& o, mic::VectorRecord* remote, mic::ScalarRecord* scalar) {
  mic::SimulationSettings s = o.s;
  s.keep_clean_field = o.remote || o.scalar;  // the remote and the scalar record the clean field
  mic::SimulatedPair pair = mic::simulate_pair(s);
  if (o.remote) {
    mic::RemoteObservatorySettings r = o.remote_settings;
    r.seed = o.s.seed + 7000;
    *remote = mic::simulate_remote_observatory(s, pair, r);
  }
  if (o.scalar) {
    mic::ScalarMagnetometerSettings sm = o.scalar_settings;
    sm.seed = o.s.seed + 500;
    *scalar = mic::simulate_scalar_magnetometer(pair, sm);
  }
  pair.reference.values_nT *= o.reference_scale;
  if (o.station.vehicles_per_day > 0.0 || o.station.small_spikes_per_day > 0.0) mic::add_station_disturbances(pair, o.station);
  mic::add_unmodelled_disturbances(pair, o.unmodelled);
  if (o.with_hut()) mic::add_hut_temperature(pair, o.hut);
  pair.reference.station = "SIM";
  pair.test.station = "SIM";
  return pair;
}

struct RecordPaths {
  std::string reference, test;
};

/// IAGA-2002 header of a simulated record: station `code`, its name, the comments.
mic::Iaga2002WriteOptions simulated_iaga_options(const Options& o, const std::string& code, const std::string& name,
                                                 const std::vector<std::string>& comments) {
  mic::Iaga2002WriteOptions options;
  options.source_of_data = "magnetometer_insitu_calibration simulator";
  options.iaga_code = code;
  options.data_type = "variation";
  std::ostringstream sampling;
  sampling << o.s.sample_period_s << " second";
  options.digital_sampling = sampling.str();
  options.station_name = name;
  options.comments = comments;
  return options;
}

/// Writes reference.<iaga|csv> and test.<iaga|csv> into dir, with the provenance in their comments.
RecordPaths write_records(mic::SimulatedPair& pair, const Options& o, const std::filesystem::path& dir) {
  const std::string extension = o.format == "iaga" ? ".iaga" : ".csv";
  const RecordPaths paths{(dir / ("reference" + extension)).string(), (dir / ("test" + extension)).string()};
  const std::string provenance = "Simulated by magnetometer_insitu_calibration simulate_records, seed " +
                                 std::to_string(o.s.seed) + "; truth in truth.json.";
  if (o.format == "iaga") {
    mic::write_iaga2002(paths.reference, pair.reference,
                        simulated_iaga_options(o, "SIM", "Simulated reference",
                                               {provenance, "Reference instrument: R = B + noise (reference frame)."}));
    mic::write_iaga2002(paths.test, pair.test,
                        simulated_iaga_options(o, "SIM", "Simulated test",
                                               {provenance, "Test instrument: T = B(t - delay) n(t) + drift + noise (test frame)."}));
  } else {
    pair.reference.header["comments"] = provenance + "\nReference instrument: R = B + noise (reference frame), nT.";
    pair.test.header["comments"] =
        provenance + "\nTest instrument: T = B(t - delay) n(t) + drift + noise (test frame), nT.";
    mic::write_csv_record(paths.reference, pair.reference, true, o.decimals);
    mic::write_csv_record(paths.test, pair.test, true, o.decimals);
  }
  return paths;
}

/// Writes remote.<iaga|csv>; returns its part of truth.json (file, settings, mixing Q).
nlohmann::json write_remote(mic::VectorRecord& remote, const Options& o, const std::filesystem::path& dir) {
  const std::string path = (dir / (o.format == "iaga" ? "remote.iaga" : "remote.csv")).string();
  const std::string provenance = "Simulated remote observatory (simulate_records --remote, seed " +
                                 std::to_string(o.s.seed) + "): the field, none of the local disturbances.";
  if (o.format == "iaga") {
    mic::write_iaga2002(path, remote, simulated_iaga_options(o, "RMT", "Simulated remote observatory", {provenance}));
  } else {
    remote.header["comments"] = provenance;
    mic::write_csv_record(path, remote, true, o.decimals);
  }
  const mic::RemoteObservatorySettings& r = o.remote_settings;
  const Eigen::Matrix3d q = mic::remote_mixing(r);
  return {{"file", path},
          {"incoherent_fraction", r.incoherent_fraction},
          {"z_incoherent_fraction", r.z_incoherent_fraction},
          {"coherence_corner_hz", std::isinf(r.coherence_corner_hz) ? nlohmann::json() : nlohmann::json(r.coherence_corner_hz)},
          {"gap_count", r.gap_count},
          {"time_offset_s", r.time_offset_s},
          {"mixing_rows_are_samples", {{q(0, 0), q(0, 1), q(0, 2)}, {q(1, 0), q(1, 1), q(1, 2)}, {q(2, 0), q(2, 1), q(2, 2)}}}};
}

/// Writes scalar.csv (time as ISO 8601 with ms, F in nT with 4 decimals); its part of truth.json.
nlohmann::json write_scalar(const mic::ScalarRecord& scalar, const Options& o, const std::filesystem::path& dir) {
  const std::string path = (dir / "scalar.csv").string();
  std::ofstream out(path);
  out << "time,F\n";
  char line[96];
  for (std::size_t i = 0; i < scalar.size(); ++i) {
    std::snprintf(line, sizeof line, "%s,%.4f\n", mic::format_iso8601(scalar.time_s[i], 3).c_str(), scalar.value_nT[i]);
    out << line;
  }
  out.close();
  if (!out) throw mic::InputError(path, "write failed");
  return {{"file", path},
          {"period_s", o.scalar_settings.period_s},
          {"offset_s", o.scalar_settings.offset_s},
          {"white_nT", o.scalar_settings.white_nT},
          {"model", "F(t_k) = |B(t_k)| + noise; the reference reads reference_scale B"}};
}

/// truth.json: the simulation's truth, the files, the disturbances' settings and the command line.
nlohmann::json truth_json(const Options& o, const mic::SimulatedPair& pair, const RecordPaths& paths, int argc,
                          char** argv) {
  nlohmann::json truth = nlohmann::json::parse(mic::simulation_truth_json(o.s, pair));
  truth["files"] = {{"format", o.format == "iaga" ? "IAGA-2002" : "CSV"},
                    {"reference", paths.reference},
                    {"test", paths.test}};
  truth["start"] = mic::format_iso8601(o.s.start_time_s, 3);
  truth["traffic"] = {{"vehicles_per_day", o.station.vehicles_per_day},
                      {"road_distance_m", o.station.road_distance_m},
                      {"parking_probability", o.station.parking_probability}};
  const mic::UnmodelledDisturbanceSettings& u = o.unmodelled;
  truth["test_only"] = {{"pier_tilt_walk_nT_per_sqrt_day", u.tilt_walk_nT_per_sqrt_day},
                        {"heater_nT", {u.heater_nT(0), u.heater_nT(1), u.heater_nT(2)}},
                        {"heater_period_s", u.heater_period_s},
                        {"test_corner_hz", u.test_corner_hz},
                        {"test_delay_s", u.test_delay_s}};
  if (o.with_hut()) {
    const mic::HutTemperatureSettings& hut = o.hut;
    auto v3 = [](const Eigen::Vector3d& v) { return nlohmann::json::array({v(0), v(1), v(2)}); };
    truth["hut"] = {{"mean_C", hut.mean_C},
                    {"reference_C", hut.reference_C},
                    {"daily_amplitude_C", hut.daily_amplitude_C},
                    {"heater_amplitude_C", hut.heater_amplitude_C},
                    {"heater_period_s", hut.heater_period_s},
                    {"offset_nT_per_C", v3(hut.offset_nT_per_C)},
                    {"scale_ppm_per_C", v3(hut.scale_ppm_per_C)},
                    {"model", "T_l <- T_l (1 + 1e-6 scale_l (theta - reference_C)) + offset_l (theta - reference_C)"}};
  }
  std::string command_line;
  for (int i = 0; i < argc; ++i) command_line += (i ? " " : "") + std::string(argv[i]);
  truth["command_line"] = command_line;
  return truth;
}

/// Writes dir/truth.json (2-space indent); returns its path.
std::string write_truth(const nlohmann::json& truth, const std::filesystem::path& dir) {
  const std::string truth_path = (dir / "truth.json").string();
  std::ofstream out(truth_path);
  out << truth.dump(2) << "\n";
  out.close();
  if (!out) throw mic::InputError(truth_path, "write failed");
  return truth_path;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Simulates a reference and a test magnetometer recording the same field, with known truth "
      "(T = B(t - delay) n(t) + drift + noise, R = B + noise), and writes both records and "
      "truth.json."};
  Options o;
  add_record_options(app, o);
  add_disturbance_options(app, o);
  add_hut_and_format_options(app, o);
  add_remote_options(app, o);
  if (const auto status = mic::parse_command_line(app, argc, argv)) return *status;

  try {
    read_texts(o);
    validate(o);
    const std::filesystem::path dir = make_out_dir(o.out_dir);
    mic::VectorRecord remote;
    mic::ScalarRecord scalar;
    mic::SimulatedPair pair = simulate(o, &remote, &scalar);
    const RecordPaths paths = write_records(pair, o, dir);
    nlohmann::json truth = truth_json(o, pair, paths, argc, argv);
    std::string also;  // the optional records, named in the summary line too
    if (o.remote) {
      truth["remote"] = write_remote(remote, o, dir);
      also += ", " + truth["remote"]["file"].get<std::string>();
    }
    if (o.scalar) {
      truth["scalar"] = write_scalar(scalar, o, dir);
      also += ", " + truth["scalar"]["file"].get<std::string>();
    }
    truth["reference_scale"] = o.reference_scale;
    const std::string truth_path = write_truth(truth, dir);
    std::cout << "wrote " << paths.reference << ", " << paths.test << " (" << pair.reference.size()
              << " samples each)" << also << " and " << truth_path << "\n";
  } catch (const mic::InputError& e) {
    std::cerr << "simulate_records: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "simulate_records: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
