// Calibration file: MagnetometerCalibration <-> YAML, atomic write.
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"

#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"

#include <yaml-cpp/yaml.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <limits>
#include <sstream>
#include <sys/stat.h>
#include <unistd.h>

namespace magnetometer_insitu_calibration {

namespace {

// 5: the covariance's cells and the intervals' quantile; 4: temperature terms; 3: reference mean;
// 2: method, band used, delay, offset (1-4 still load)
constexpr int kFormatVersion = 5;

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

bool reals_equal(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }

}  // namespace

std::string calibration_to_yaml(const MagnetometerCalibration& c, const std::string& written_by) {
  std::ostringstream y;
  y << "# Magnetometer in-situ calibration (magnetometer_insitu_calibration/MagnetometerCalibration).\n"
       "# Model, rows are samples, nT: T = R n + offset + trend; column l of n is test axis l in\n"
       "# reference coordinates. correction_node applies r = n^-T (t - offset_nT) (column vectors;\n"
       "# r = n^-T t with ~apply_offset false). Do not edit by hand:\n"
       "# a malformed or incomplete file is refused as a whole.\n";
  y << "format_version: " << kFormatVersion << "\n";
  y << "written_by: " << quoted(written_by) << "\n";
  y << "test_name: " << quoted(c.test_name) << "\n";
  y << "stamp: " << time_text(c.header.stamp) << "\n";
  y << "frame_id: " << quoted(c.header.frame_id) << "\n";
  y << "reference_frame_id: " << quoted(c.reference_frame_id) << "\n";
  y << "test_frame_id: " << quoted(c.test_frame_id) << "\n";
  y << "window_start: " << time_text(c.window_start) << "\n";
  y << "window_end: " << time_text(c.window_end) << "\n";
  y << "sample_period: " << number(c.sample_period) << "  # s\n";
  y << "samples: " << c.samples << "\n";
  y << "filled_samples: " << c.filled_samples << "\n";
  y << "band_low_hz: " << number(c.band_low_hz) << "\n";
  y << "band_high_hz: " << number(c.band_high_hz) << "\n";
  y << "harmonic_first: " << c.harmonic_first << "\n";
  y << "harmonic_last: " << c.harmonic_last << "\n";
  y << "gamma: " << number(c.gamma) << "\n";
  y << "trend_column: " << (c.trend_column ? "true" : "false") << "\n";
  y << "method: " << quoted(c.method) << "\n";
  y << "band_used_low_hz: " << number(c.band_used_low_hz) << "\n";
  y << "band_used_high_hz: " << number(c.band_used_high_hz) << "\n";
  y << "delay_s: " << number(c.delay_s) << "  # test minus reference, s\n";
  y << "delay_ci95_s: " << number(c.delay_ci95_s) << "\n";
  y << "matrix: " << list(c.matrix) << "  # n, row-major, T = R n\n";
  y << "matrix_covariance: " << list(c.matrix_covariance) << "  # 9x9, row-major vec(n)\n";
  y << "covariance_cells: " << number(c.covariance_cells) << "  # its degrees of freedom\n";
  y << "interval_quantile: " << number(c.interval_quantile) << "  # *_ci95 / standard error\n";
  y << "trend_nT_per_day: " << list(c.trend_nT_per_day) << "\n";
  y << "trend_ci95_nT_per_day: " << list(c.trend_ci95_nT_per_day) << "\n";
  y << "offset_nT: " << list(c.offset_nT) << "  # test relative to reference at window_end, test frame\n";
  y << "offset_ci95_nT: " << list(c.offset_ci95_nT) << "\n";
  y << "reference_mean_nT: " << list(c.reference_mean_nT) << "  # mean(R) over the window, reference frame\n";
  y << "scale_ratio: " << list(c.scale_ratio) << "\n";
  y << "scale_ratio_ci95: " << list(c.scale_ratio_ci95) << "\n";
  y << "nonorthogonality_deg: " << list(c.nonorthogonality_deg) << "  # xy, xz, yz\n";
  y << "nonorthogonality_ci95_deg: " << list(c.nonorthogonality_ci95_deg) << "\n";
  y << "misalignment_deg: " << list(c.misalignment_deg) << "\n";
  y << "misalignment_ci95_deg: " << list(c.misalignment_ci95_deg) << "\n";
  y << "axis_deviation_deg: " << list(c.axis_deviation_deg) << "\n";
  y << "axis_deviation_ci95_deg: " << list(c.axis_deviation_ci95_deg) << "\n";
  y << "condition_number: " << number(c.condition_number) << "\n";
  y << "coherence: " << list(c.coherence) << "\n";
  y << "residual_rms_nT: " << list(c.residual_rms_nT) << "\n";
  y << "quality: " << static_cast<int>(c.quality) << "\n";
  y << "quality_text: " << quoted(c.quality_text) << "\n";
  y << "temperature_fitted: " << (c.temperature_fitted ? "true" : "false") << "\n";
  y << "temperature_text: " << quoted(c.temperature_text) << "\n";
  y << "temperature_reference_C: " << number(c.temperature_reference_C) << "  # deg C, n and offset_nT at it\n";
  y << "temperature_range_C: " << number(c.temperature_range_C) << "  # deg C\n";
  y << "temperature_apparent_nT_per_C: " << list(c.temperature_apparent_nT_per_C) << "  # c + s F, test frame\n";
  y << "temperature_apparent_ci95_nT_per_C: " << list(c.temperature_apparent_ci95_nT_per_C) << "\n";
  y << "temperature_offset_nT_per_C: " << list(c.temperature_offset_nT_per_C) << "  # c\n";
  y << "temperature_offset_ci95_nT_per_C: " << list(c.temperature_offset_ci95_nT_per_C) << "\n";
  y << "temperature_scale_ppm_per_C: " << list(c.temperature_scale_ppm_per_C) << "  # s\n";
  y << "temperature_scale_ci95_ppm_per_C: " << list(c.temperature_scale_ci95_ppm_per_C) << "\n";
  y << "accepted: " << (c.accepted ? "true" : "false") << "  # last line\n";
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
  if (version < 1 || version > kFormatVersion) {
    throw CalibrationFileError(source + ": format_version " + std::to_string(version) + " is not supported (expected " +
                               std::to_string(kFormatVersion) + ")");
  }
  const long long u32 = std::numeric_limits<std::uint32_t>::max();
  MagnetometerCalibration c;
  c.test_name = r.text("test_name");
  c.header.stamp = r.time("stamp");
  c.header.frame_id = r.text("frame_id");
  c.reference_frame_id = r.text("reference_frame_id");
  c.test_frame_id = r.text("test_frame_id");
  c.window_start = r.time("window_start");
  c.window_end = r.time("window_end");
  c.sample_period = r.real("sample_period");
  c.samples = static_cast<std::uint32_t>(r.integer("samples", 0, u32));
  c.filled_samples = static_cast<std::uint32_t>(r.integer("filled_samples", 0, u32));
  c.band_low_hz = r.real("band_low_hz");
  c.band_high_hz = r.real("band_high_hz");
  c.harmonic_first = static_cast<std::uint32_t>(r.integer("harmonic_first", 0, u32));
  c.harmonic_last = static_cast<std::uint32_t>(r.integer("harmonic_last", 0, u32));
  c.gamma = r.real("gamma");
  c.trend_column = r.boolean("trend_column");
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (version >= 2) {
    c.method = r.text("method");
    c.band_used_low_hz = r.real("band_used_low_hz");
    c.band_used_high_hz = r.real("band_used_high_hz");
    c.delay_s = r.real("delay_s");
    c.delay_ci95_s = r.real("delay_ci95_s");
  } else {  // format 1: plain estimator, requested band, no delay, no offset (0: none applied)
    c.method = "plain";
    c.band_used_low_hz = c.band_low_hz;
    c.band_used_high_hz = c.band_high_hz;
    c.delay_s = nan;
    c.delay_ci95_s = nan;
    c.offset_nT = {0.0, 0.0, 0.0};
    c.offset_ci95_nT = {nan, nan, nan};
  }
  r.array("matrix", c.matrix);
  r.array("matrix_covariance", c.matrix_covariance);
  if (version >= 5) {
    c.covariance_cells = r.real("covariance_cells");
    if (!(c.covariance_cells > 0.0)) r.fail("covariance_cells", "must be positive (.inf: taken as known)");
    c.interval_quantile = r.real("interval_quantile");
    // Student's two-sided 5 % quantile lies between the normal's 1.96 and 12.71 (one dof).
    if (!(c.interval_quantile >= 1.95 && c.interval_quantile <= 12.8))
      r.fail("interval_quantile", "must be in [1.95, 12.8]");
  } else {  // formats 1-4: the covariance taken as known, intervals of 1.96 standard errors
    c.covariance_cells = std::numeric_limits<double>::infinity();
    c.interval_quantile = kNormalQuantile95;
  }
  r.array("trend_nT_per_day", c.trend_nT_per_day);
  r.array("trend_ci95_nT_per_day", c.trend_ci95_nT_per_day);
  if (version >= 2) {
    r.array("offset_nT", c.offset_nT);
    r.array("offset_ci95_nT", c.offset_ci95_nT);
  }
  // Formats 1 and 2 have no reference mean: 0 makes correction_node propagate n's uncertainty
  // with the whole field (the conservative form used before format 3).
  c.reference_mean_nT = {0.0, 0.0, 0.0};
  if (version >= 3) r.array("reference_mean_nT", c.reference_mean_nT);
  r.array("scale_ratio", c.scale_ratio);
  r.array("scale_ratio_ci95", c.scale_ratio_ci95);
  r.array("nonorthogonality_deg", c.nonorthogonality_deg);
  r.array("nonorthogonality_ci95_deg", c.nonorthogonality_ci95_deg);
  r.array("misalignment_deg", c.misalignment_deg);
  r.array("misalignment_ci95_deg", c.misalignment_ci95_deg);
  r.array("axis_deviation_deg", c.axis_deviation_deg);
  r.array("axis_deviation_ci95_deg", c.axis_deviation_ci95_deg);
  c.condition_number = r.real("condition_number");
  r.array("coherence", c.coherence);
  r.array("residual_rms_nT", c.residual_rms_nT);
  c.quality = static_cast<std::uint8_t>(r.integer("quality", 0, 255));
  c.quality_text = r.text("quality_text");
  if (version >= 4) {
    c.temperature_fitted = r.boolean("temperature_fitted");
    c.temperature_text = r.text("temperature_text");
    c.temperature_reference_C = r.real("temperature_reference_C");
    c.temperature_range_C = r.real("temperature_range_C");
    r.array("temperature_apparent_nT_per_C", c.temperature_apparent_nT_per_C);
    r.array("temperature_apparent_ci95_nT_per_C", c.temperature_apparent_ci95_nT_per_C);
    r.array("temperature_offset_nT_per_C", c.temperature_offset_nT_per_C);
    r.array("temperature_offset_ci95_nT_per_C", c.temperature_offset_ci95_nT_per_C);
    r.array("temperature_scale_ppm_per_C", c.temperature_scale_ppm_per_C);
    r.array("temperature_scale_ci95_ppm_per_C", c.temperature_scale_ci95_ppm_per_C);
  } else {  // formats 1-3: no temperature terms (correction_node corrects without temperature)
    c.temperature_fitted = false;
    c.temperature_text = "calibration file format " + std::to_string(version) + " has no temperature terms";
    c.temperature_reference_C = c.temperature_range_C = nan;
    for (auto* a : {&c.temperature_apparent_nT_per_C, &c.temperature_apparent_ci95_nT_per_C,
                    &c.temperature_offset_nT_per_C, &c.temperature_offset_ci95_nT_per_C,
                    &c.temperature_scale_ppm_per_C, &c.temperature_scale_ci95_ppm_per_C}) {
      a->fill(nan);
    }
  }
  c.accepted = r.boolean("accepted");
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

void write_file_atomically(const std::string& path, const std::string& text) {
  const std::size_t slash = path.rfind('/');
  const std::string directory = slash == std::string::npos ? "." : (slash == 0 ? "/" : path.substr(0, slash));
  const std::string base = slash == std::string::npos ? path : path.substr(slash + 1);
  const std::string temporary = directory + "/." + base + ".tmp." + std::to_string(::getpid());
  auto fail = [&](const std::string& what) -> void {
    const std::string reason = std::strerror(errno);
    ::unlink(temporary.c_str());
    throw std::runtime_error(path + ": " + what + " (" + reason + ")");
  };
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) {
    const std::string reason = std::strerror(errno);
    throw std::runtime_error(path + ": cannot create temporary file " + temporary + " (" + reason + ")");
  }
  std::size_t written = 0;
  while (written < text.size()) {
    const ssize_t n = ::write(fd, text.data() + written, text.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      ::close(fd);
      fail("write failed");
    }
    written += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0) {
    ::close(fd);
    fail("fsync failed");
  }
  if (::close(fd) != 0) fail("close failed");
  if (::rename(temporary.c_str(), path.c_str()) != 0) fail("rename failed");
  // Make the rename itself durable (best effort: some file systems refuse fsync on directories).
  const int dir_fd = ::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir_fd >= 0) {
    (void)::fsync(dir_fd);
    ::close(dir_fd);
  }
}

bool calibrations_equal(const MagnetometerCalibration& a, const MagnetometerCalibration& b, std::string* difference) {
  auto differ = [&](const char* field) {
    if (difference != nullptr) *difference = field;
    return false;
  };
#define MIC_SAME(field, same) \
  if (!(same)) return differ(#field);
  MIC_SAME(test_name, a.test_name == b.test_name)
  MIC_SAME(header.stamp, a.header.stamp == b.header.stamp)
  MIC_SAME(header.frame_id, a.header.frame_id == b.header.frame_id)
  MIC_SAME(reference_frame_id, a.reference_frame_id == b.reference_frame_id)
  MIC_SAME(test_frame_id, a.test_frame_id == b.test_frame_id)
  MIC_SAME(window_start, a.window_start == b.window_start)
  MIC_SAME(window_end, a.window_end == b.window_end)
  MIC_SAME(sample_period, reals_equal(a.sample_period, b.sample_period))
  MIC_SAME(samples, a.samples == b.samples)
  MIC_SAME(filled_samples, a.filled_samples == b.filled_samples)
  MIC_SAME(band_low_hz, reals_equal(a.band_low_hz, b.band_low_hz))
  MIC_SAME(band_high_hz, reals_equal(a.band_high_hz, b.band_high_hz))
  MIC_SAME(harmonic_first, a.harmonic_first == b.harmonic_first)
  MIC_SAME(harmonic_last, a.harmonic_last == b.harmonic_last)
  MIC_SAME(gamma, reals_equal(a.gamma, b.gamma))
  MIC_SAME(trend_column, a.trend_column == b.trend_column)
  MIC_SAME(method, a.method == b.method)
  MIC_SAME(band_used_low_hz, reals_equal(a.band_used_low_hz, b.band_used_low_hz))
  MIC_SAME(band_used_high_hz, reals_equal(a.band_used_high_hz, b.band_used_high_hz))
  MIC_SAME(delay_s, reals_equal(a.delay_s, b.delay_s))
  MIC_SAME(delay_ci95_s, reals_equal(a.delay_ci95_s, b.delay_ci95_s))
  MIC_SAME(matrix, arrays_equal(a.matrix, b.matrix))
  MIC_SAME(matrix_covariance, arrays_equal(a.matrix_covariance, b.matrix_covariance))
  MIC_SAME(trend_nT_per_day, arrays_equal(a.trend_nT_per_day, b.trend_nT_per_day))
  MIC_SAME(covariance_cells, reals_equal(a.covariance_cells, b.covariance_cells))
  MIC_SAME(interval_quantile, reals_equal(a.interval_quantile, b.interval_quantile))
  MIC_SAME(trend_ci95_nT_per_day, arrays_equal(a.trend_ci95_nT_per_day, b.trend_ci95_nT_per_day))
  MIC_SAME(offset_nT, arrays_equal(a.offset_nT, b.offset_nT))
  MIC_SAME(offset_ci95_nT, arrays_equal(a.offset_ci95_nT, b.offset_ci95_nT))
  MIC_SAME(reference_mean_nT, arrays_equal(a.reference_mean_nT, b.reference_mean_nT))
  MIC_SAME(scale_ratio, arrays_equal(a.scale_ratio, b.scale_ratio))
  MIC_SAME(scale_ratio_ci95, arrays_equal(a.scale_ratio_ci95, b.scale_ratio_ci95))
  MIC_SAME(nonorthogonality_deg, arrays_equal(a.nonorthogonality_deg, b.nonorthogonality_deg))
  MIC_SAME(nonorthogonality_ci95_deg, arrays_equal(a.nonorthogonality_ci95_deg, b.nonorthogonality_ci95_deg))
  MIC_SAME(misalignment_deg, arrays_equal(a.misalignment_deg, b.misalignment_deg))
  MIC_SAME(misalignment_ci95_deg, arrays_equal(a.misalignment_ci95_deg, b.misalignment_ci95_deg))
  MIC_SAME(axis_deviation_deg, arrays_equal(a.axis_deviation_deg, b.axis_deviation_deg))
  MIC_SAME(axis_deviation_ci95_deg, arrays_equal(a.axis_deviation_ci95_deg, b.axis_deviation_ci95_deg))
  MIC_SAME(condition_number, reals_equal(a.condition_number, b.condition_number))
  MIC_SAME(coherence, arrays_equal(a.coherence, b.coherence))
  MIC_SAME(residual_rms_nT, arrays_equal(a.residual_rms_nT, b.residual_rms_nT))
  MIC_SAME(quality, a.quality == b.quality)
  MIC_SAME(quality_text, a.quality_text == b.quality_text)
  MIC_SAME(temperature_fitted, a.temperature_fitted == b.temperature_fitted)
  MIC_SAME(temperature_text, a.temperature_text == b.temperature_text)
  MIC_SAME(temperature_reference_C, reals_equal(a.temperature_reference_C, b.temperature_reference_C))
  MIC_SAME(temperature_range_C, reals_equal(a.temperature_range_C, b.temperature_range_C))
  MIC_SAME(temperature_apparent_nT_per_C, arrays_equal(a.temperature_apparent_nT_per_C, b.temperature_apparent_nT_per_C))
  MIC_SAME(temperature_apparent_ci95_nT_per_C,
           arrays_equal(a.temperature_apparent_ci95_nT_per_C, b.temperature_apparent_ci95_nT_per_C))
  MIC_SAME(temperature_offset_nT_per_C, arrays_equal(a.temperature_offset_nT_per_C, b.temperature_offset_nT_per_C))
  MIC_SAME(temperature_offset_ci95_nT_per_C,
           arrays_equal(a.temperature_offset_ci95_nT_per_C, b.temperature_offset_ci95_nT_per_C))
  MIC_SAME(temperature_scale_ppm_per_C, arrays_equal(a.temperature_scale_ppm_per_C, b.temperature_scale_ppm_per_C))
  MIC_SAME(temperature_scale_ci95_ppm_per_C,
           arrays_equal(a.temperature_scale_ci95_ppm_per_C, b.temperature_scale_ci95_ppm_per_C))
  MIC_SAME(accepted, a.accepted == b.accepted)
#undef MIC_SAME
  return true;
}

}  // namespace magnetometer_insitu_calibration
