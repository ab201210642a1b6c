// Scalar magnetometer records: see scalar_record.hpp.
#include "magnetometer_insitu_calibration/formats/scalar_record.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/formats/cdf_epoch.hpp"
#include "magnetometer_insitu_calibration/formats/cdf_file.hpp"
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace magnetometer_insitu_calibration {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// The time variable a CDF variable depends on (its DEPEND_0 attribute), else `fallback`.
std::string depend_0(const CdfVariable& v, const std::string& fallback) {
  for (const auto& a : v.attributes)
    if (a.first == "DEPEND_0" && !a.second.text.empty()) return a.second.text;
  return fallback;
}

ScalarRecord from_cdf(const std::string& path) {
  const CdfFile file = CdfFile::open(path);
  const CdfVariable* f = file.find("f");
  std::string time_name;
  if (f != nullptr) {
    time_name = depend_0(*f, "Epoch");
  } else if ((f = file.find("GeomagneticFieldF")) != nullptr) {
    time_name = depend_0(*f, file.find("GeomagneticScalarTimes") ? "GeomagneticScalarTimes" : "GeomagneticVectorTimes");
  } else {
    throw InputError(path, "no scalar field: neither MagPy's variable f nor ImagCDF's GeomagneticFieldF");
  }
  const CdfVariable* t = file.find(time_name);
  if (t == nullptr || t->data_type != kCdfTimeTt2000) {
    throw InputError(path, "the scalar field's time variable '" + time_name + "' is missing or not CDF_TT2000");
  }
  const std::vector<std::int64_t> tt = file.read_int64(*t);
  const std::vector<double> values = file.read_real(*f);
  if (tt.size() != values.size()) {
    throw InputError(path, "'" + f->name + "' has " + std::to_string(values.size()) + " values for " +
                               std::to_string(tt.size()) + " times");
  }
  ScalarRecord out;
  for (std::size_t i = 0; i < tt.size(); ++i) {
    double unix_s = 0.0;
    if (tt2000_to_unix(tt[i], unix_s) != Tt2000Status::kOk) continue;
    out.time_s.push_back(unix_s);
    out.value_nT.push_back(values[i] >= 88888.0 || !std::isfinite(values[i]) ? kNaN : values[i]);
  }
  out.station = file.global_text("StationIAGAcode");
  if (out.station.empty()) out.station = file.global_text("SensorID");
  return out;
}

ScalarRecord from_iaga2002(const std::string& path) {
  const VectorRecord r = read_iaga2002(path);
  const auto f = std::find_if(r.auxiliary.begin(), r.auxiliary.end(), [](const AuxiliaryChannel& c) { return c.name == "F"; });
  if (f == r.auxiliary.end()) throw InputError(path, "its fourth column holds no F (scalar field) values");
  ScalarRecord out;
  out.time_s = r.time_s;
  out.value_nT = f->values;
  out.station = r.station;
  return out;
}

/// "time,F" lines: UNIX seconds or ISO 8601, then nT; a first line that is not a time is a header.
ScalarRecord from_csv(const std::string& path) {
  TextLineReader reader(path);
  ScalarRecord out;
  std::string line;
  while (reader.next(line)) {
    const std::size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    const std::size_t comma = line.find_first_of(",;\t", first);
    if (comma == std::string::npos) throw InputError(path, reader.line_number(), "expected 'time,F'");
    const std::string time_text = line.substr(first, comma - first), value_text = line.substr(comma + 1);
    double t = 0.0;
    char* end = nullptr;
    t = std::strtod(time_text.c_str(), &end);
    if (end == time_text.c_str() || *end != '\0') {
      try {
        t = parse_iso8601(time_text);
      } catch (const std::invalid_argument&) {
        if (out.time_s.empty() && reader.line_number() <= 1 + first) continue;  // a header line
        if (out.time_s.empty()) continue;
        throw InputError(path, reader.line_number(), "column 1 (time): '" + time_text + "' is not a time");
      }
    }
    const double v = std::strtod(value_text.c_str(), &end);
    if (end == value_text.c_str()) throw InputError(path, reader.line_number(), "column 2 (F): '" + value_text + "' is not a number");
    if (!out.time_s.empty() && !(t > out.time_s.back())) {
      throw InputError(path, reader.line_number(), "time " + time_for_message(t) + " is not after the previous one");
    }
    out.time_s.push_back(t);
    out.value_nT.push_back(v >= 88888.0 ? kNaN : v);
  }
  return out;
}

}  // namespace

ScalarRecord read_scalar_record(const std::string& path) {
  const RecordFormat format = detect_record_format(path);
  ScalarRecord out;
  if (format == RecordFormat::kCdf) out = from_cdf(path);
  else if (format == RecordFormat::kIaga2002) out = from_iaga2002(path);
  else if (format == RecordFormat::kCsv) out = from_csv(path);
  else throw InputError(path, std::string("a ") + record_format_name(format) + " file holds no scalar field");
  out.source = path;
  if (out.time_s.empty()) throw InputError(path, "no scalar sample");
  for (std::size_t i = 1; i < out.time_s.size(); ++i) {
    if (!(out.time_s[i] > out.time_s[i - 1])) {
      throw InputError(path, "scalar times do not increase at " + time_for_message(out.time_s[i]));
    }
  }
  return out;
}

ScalarRecord read_scalar_records(const std::vector<std::string>& paths) {
  if (paths.empty()) throw InputError("--scalar", "no file");
  std::vector<ScalarRecord> parts;
  for (const std::string& p : paths) parts.push_back(read_scalar_record(p));
  std::sort(parts.begin(), parts.end(), [](const ScalarRecord& a, const ScalarRecord& b) { return a.time_s.front() < b.time_s.front(); });
  ScalarRecord out = parts.front();
  for (std::size_t k = 1; k < parts.size(); ++k) {
    if (!(parts[k].time_s.front() > out.time_s.back())) {
      throw InputError(parts[k].source, "overlaps " + parts[k - 1].source + " (scalar files must follow each other)");
    }
    out.time_s.insert(out.time_s.end(), parts[k].time_s.begin(), parts[k].time_s.end());
    out.value_nT.insert(out.value_nT.end(), parts[k].value_nT.begin(), parts[k].value_nT.end());
    out.source += " + " + parts[k].source;
  }
  return out;
}

}  // namespace magnetometer_insitu_calibration
