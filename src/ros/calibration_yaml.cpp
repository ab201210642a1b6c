// Calibration file: MagnetometerCalibration <-> YAML, atomic write.
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"

#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_record.hpp"

#include <yaml-cpp/yaml.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

namespace magnetometer_insitu_calibration {

namespace {

std::string number(double value) {
  if (std::isnan(value)) return ".nan";
  if (std::isinf(value)) return value > 0 ? ".inf" : "-.inf";
  char buffer[40];
  std::snprintf(buffer, sizeof(buffer), "%.17g", value);
  return buffer;
}

std::string quoted(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out + "\"";
}

template <typename Array>
std::string list(const Array& values) {
  std::string out = "[";
  for (std::size_t i = 0; i < values.size(); ++i) out += (i ? ", " : "") + number(values[i]);
  return out + "]";
}

std::string time_text(const ros::Time& t) {
  std::string iso;
  try {
    iso = format_iso8601(t.toSec(), 3);
  } catch (const std::exception&) {
    iso = "out of range";
  }
  return "{secs: " + std::to_string(t.sec) + ", nsecs: " + std::to_string(t.nsec) + "}  # " + iso;
}

// --- reading ---------------------------------------------------------------------------------

struct Reader {
  const YAML::Node& root;
  const std::string& source;

  [[noreturn]] void fail(const std::string& key, const std::string& problem) const {
    throw CalibrationFileError(source + ": field '" + key + "' " + problem);
  }
  YAML::Node field(const std::string& key) const {
    const YAML::Node node = root[key];
    if (!node.IsDefined() || node.IsNull()) fail(key, "is missing (malformed or half-written file?)");
    return node;
  }
  template <typename T>
  T scalar(const std::string& key, const YAML::Node& node, const char* expected) const {
    if (!node.IsScalar()) fail(key, std::string("must be ") + expected);
    try {
      return node.as<T>();
    } catch (const YAML::Exception&) {
      fail(key, std::string("must be ") + expected + ", not '" + node.Scalar() + "'");
    }
  }
  double real(const std::string& key) const { return scalar<double>(key, field(key), "a number"); }
  bool boolean(const std::string& key) const { return scalar<bool>(key, field(key), "true or false"); }
  std::string text(const std::string& key) const { return scalar<std::string>(key, field(key), "a string"); }
  long long integer(const std::string& key, long long low, long long high) const {
    const long long v = scalar<long long>(key, field(key), "an integer");
    if (v < low || v > high) fail(key, "is out of range [" + std::to_string(low) + ", " + std::to_string(high) + "]");
    return v;
  }
  template <std::size_t N>
  void array(const std::string& key, boost::array<double, N>& out) const {
    const YAML::Node node = field(key);
    if (!node.IsSequence() || node.size() != N) fail(key, "must be a list of " + std::to_string(N) + " numbers");
    for (std::size_t i = 0; i < N; ++i) out[i] = scalar<double>(key, node[i], "a list of numbers");
  }
  ros::Time time(const std::string& key) const {
    const YAML::Node node = field(key);
    if (!node.IsMap()) fail(key, "must be {secs: S, nsecs: NS}");
    const YAML::Node secs = node["secs"], nsecs = node["nsecs"];
    if (!secs.IsDefined() || !nsecs.IsDefined()) fail(key, "must be {secs: S, nsecs: NS}");
    const long long s = scalar<long long>(key + ".secs", secs, "an integer");
    const long long ns = scalar<long long>(key + ".nsecs", nsecs, "an integer");
    if (s < 0 || s > std::numeric_limits<std::uint32_t>::max() || ns < 0 || ns >= 1000000000LL) {
      fail(key, "is out of range");
    }
    return ros::Time(static_cast<std::uint32_t>(s), static_cast<std::uint32_t>(ns));
  }
};

template <typename Array>
bool arrays_equal(const Array& a, const Array& b) {
  for (std::size_t i = 0; i < a.size(); ++i) {
    // NaN == NaN here: the file stores it as .nan and it loads back as NaN.
    if (!(a[i] == b[i] || (std::isnan(a[i]) && std::isnan(b[i])))) return false;
  }
  return true;
}

// --- one writer, reader and comparison per kind of field (pipeline/calibration_record.hpp),
// on the message's types -------------------------------------------------------------------------

using u8 = std::uint8_t;
using u32 = std::uint32_t;
template <std::size_t N>
using Reals = boost::array<double, N>;

std::string yaml_Text(const std::string& v) { return quoted(v); }
std::string yaml_Time(const ros::Time& t) { return time_text(t); }
std::string yaml_Real(double v) { return number(v); }
std::string yaml_Count(u32 v) { return std::to_string(v); }
std::string yaml_Flag(u8 v) { return v ? "true" : "false"; }
std::string yaml_Quality(u8 v) { return std::to_string(static_cast<int>(v)); }
std::string yaml_Vector3(const Reals<3>& v) { return list(v); }
std::string yaml_Pairs3(const Reals<3>& v) { return list(v); }
std::string yaml_Matrix9(const Reals<9>& v) { return list(v); }
std::string yaml_Matrix81(const Reals<81>& v) { return list(v); }

void read_Text(const Reader& r, const char* key, std::string& out) { out = r.text(key); }
void read_Time(const Reader& r, const char* key, ros::Time& out) { out = r.time(key); }
void read_Real(const Reader& r, const char* key, double& out) { out = r.real(key); }
void read_Count(const Reader& r, const char* key, u32& out) {
  out = static_cast<u32>(r.integer(key, 0, std::numeric_limits<u32>::max()));
}
void read_Flag(const Reader& r, const char* key, u8& out) { out = r.boolean(key); }
void read_Quality(const Reader& r, const char* key, u8& out) { out = static_cast<u8>(r.integer(key, 0, 255)); }
template <std::size_t N>
void read_reals(const Reader& r, const char* key, Reals<N>& out) {
  r.array(key, out);
}
void read_Vector3(const Reader& r, const char* key, Reals<3>& out) { read_reals(r, key, out); }
void read_Pairs3(const Reader& r, const char* key, Reals<3>& out) { read_reals(r, key, out); }
void read_Matrix9(const Reader& r, const char* key, Reals<9>& out) { read_reals(r, key, out); }
void read_Matrix81(const Reader& r, const char* key, Reals<81>& out) { read_reals(r, key, out); }

bool same_Text(const std::string& a, const std::string& b) { return a == b; }
bool same_Time(const ros::Time& a, const ros::Time& b) { return a == b; }
bool same_Real(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }
bool same_Count(u32 a, u32 b) { return a == b; }
bool same_Flag(u8 a, u8 b) { return (a != 0) == (b != 0); }
bool same_Quality(u8 a, u8 b) { return a == b; }
bool same_Vector3(const Reals<3>& a, const Reals<3>& b) { return arrays_equal(a, b); }
bool same_Pairs3(const Reals<3>& a, const Reals<3>& b) { return arrays_equal(a, b); }
bool same_Matrix9(const Reals<9>& a, const Reals<9>& b) { return arrays_equal(a, b); }
bool same_Matrix81(const Reals<81>& a, const Reals<81>& b) { return arrays_equal(a, b); }

/// The fields a file of an older format lacks (their `since` is above its version), as they
/// were meant before they were written.
void fill_older_format(MagnetometerCalibration& c, long long version) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (version < 2) {  // plain estimator, requested band, no delay, no offset (0: none applied)
    c.method = "plain";
    c.band_used_low_hz = c.band_low_hz;
    c.band_used_high_hz = c.band_high_hz;
    c.delay_s = c.delay_ci95_s = nan;
    c.offset_nT = {0.0, 0.0, 0.0};
    c.offset_ci95_nT = {nan, nan, nan};
  }
  // No reference mean: 0 makes correction_node propagate n's uncertainty with the whole field
  // (the conservative form used before it was written).
  if (version < 3) c.reference_mean_nT = {0.0, 0.0, 0.0};
  if (version < 4) {  // no temperature terms: correction_node corrects without temperature
    c.temperature_fitted = false;
    c.temperature_text = "calibration file format " + std::to_string(version) + " has no temperature terms";
    c.temperature_reference_C = c.temperature_range_C = nan;
    for (auto* a : {&c.temperature_apparent_nT_per_C, &c.temperature_apparent_ci95_nT_per_C,
                    &c.temperature_offset_nT_per_C, &c.temperature_offset_ci95_nT_per_C,
                    &c.temperature_scale_ppm_per_C, &c.temperature_scale_ci95_ppm_per_C}) {
      a->fill(nan);
    }
  }
  if (version < 7) {  // no local-event check
    c.local_events_p_value = nan;
    c.local_events_seen = false;
  }
  if (version < 6) {  // no remote reference
    c.remote_used = false;
    c.pair_biased = false;
    c.remote_text = "";
    c.remote_strength = c.pair_difference_p_value = c.band_split_p_value = nan;
    c.band_split_differs = false;
    c.scalar_text = "";
    c.reference_scale_along_field = c.reference_scale_along_field_ci95 = nan;
    c.test_scale_along_field = c.test_scale_along_field_ci95 = nan;
    c.direction_cosines = c.direction_cosines_ci95 = {nan, nan, nan};
    c.reference_needs_calibration = false;
    c.remote_coherence = {nan, nan, nan};
    c.pair_only_matrix.fill(nan);
  }
  if (version < 5) {  // the covariance taken as known, intervals of 1.96 standard errors
    c.covariance_cells = std::numeric_limits<double>::infinity();
    c.interval_quantile = kNormalQuantile95;
  }
}

}  // namespace

std::string calibration_to_yaml(const MagnetometerCalibration& c, const std::string& written_by) {
  std::ostringstream y;
  y << "# Magnetometer in-situ calibration (magnetometer_insitu_calibration/MagnetometerCalibration).\n"
       "# Model, rows are samples, nT: T = R n + offset + trend; column l of n is test axis l in\n"
       "# reference coordinates. correction_node applies r = n^-T (t - offset_nT) (column vectors;\n"
       "# r = n^-T t with ~apply_offset false). Do not edit by hand:\n"
       "# a malformed or incomplete file is refused as a whole.\n";
  y << "format_version: " << kCalibrationFileFormat << "\n";
  y << "written_by: " << quoted(written_by) << "\n";
  y << "stamp: " << time_text(c.header.stamp) << "\n";
  y << "frame_id: " << quoted(c.header.frame_id) << "\n";
  auto line = [&y](const char* name, const std::string& value, const char* comment) {
    y << name << ": " << value;
    if (*comment != '\0') y << (value.find('#') == std::string::npos ? "  # " : "; ") << comment;
    y << "\n";
  };
#define MIC_WRITE_FIELD(kind, name, since, comment) line(#name, yaml_##kind(c.name), comment);
  MIC_CALIBRATION_FIELDS(MIC_WRITE_FIELD)
#undef MIC_WRITE_FIELD
  return y.str();
}

MagnetometerCalibration calibration_from_yaml(const std::string& text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw CalibrationFileError(source + ": malformed YAML: " + e.what());
  }
  if (!root.IsMap()) throw CalibrationFileError(source + ": not a calibration file (expected a YAML map)");
  const Reader r{root, source};
  const long long version = r.integer("format_version", 0, 1000);
  if (version < 1 || version > kCalibrationFileFormat) {
    throw CalibrationFileError(source + ": format_version " + std::to_string(version) + " is not supported (expected " +
                               std::to_string(kCalibrationFileFormat) + ")");
  }
  MagnetometerCalibration c;
  c.header.stamp = r.time("stamp");
  c.header.frame_id = r.text("frame_id");
#define MIC_READ_FIELD(kind, name, since, comment) \
  if (version >= (since)) read_##kind(r, #name, c.name);
  MIC_CALIBRATION_FIELDS(MIC_READ_FIELD)
#undef MIC_READ_FIELD
  fill_older_format(c, version);
  if (!(c.covariance_cells > 0.0)) r.fail("covariance_cells", "must be positive (.inf: taken as known)");
  // Student's two-sided 5 % quantile lies between the normal's 1.96 and 12.71 (one dof).
  if (!(c.interval_quantile >= 1.95 && c.interval_quantile <= 12.8)) {
    r.fail("interval_quantile", "must be in [1.95, 12.8]");
  }
  return c;
}

MagnetometerCalibration load_calibration_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw CalibrationFileError(path + ": cannot open (" + std::strerror(errno) + ")");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw CalibrationFileError(path + ": read error");
  if (text.str().empty()) throw CalibrationFileError(path + ": empty file");
  return calibration_from_yaml(text.str(), path);
}

bool calibrations_equal(const MagnetometerCalibration& a, const MagnetometerCalibration& b, std::string* difference) {
  auto differ = [&](const char* field) {
    if (difference != nullptr) *difference = field;
    return false;
  };
  if (a.header.stamp != b.header.stamp) return differ("header.stamp");
  if (a.header.frame_id != b.header.frame_id) return differ("header.frame_id");
#define MIC_SAME_FIELD(kind, name, since, comment) \
  if (!same_##kind(a.name, b.name)) return differ(#name);
  MIC_CALIBRATION_FIELDS(MIC_SAME_FIELD)
#undef MIC_SAME_FIELD
  return true;
}

}  // namespace magnetometer_insitu_calibration
