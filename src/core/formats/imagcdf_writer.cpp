// ImagCDF 1.2 writer; see imagcdf_writer.hpp.
#include "magnetometer_insitu_calibration/formats/imagcdf_writer.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/formats/cdf_epoch.hpp"
#include "magnetometer_insitu_calibration/formats/cdf_writer.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstdlib>

namespace magnetometer_insitu_calibration {

namespace {

constexpr double kFill = 99999.0, kValidField = 79999.0;

std::string header_value(const VectorRecord& r, const std::string& option, std::initializer_list<const char*> keys,
                         const std::string& fallback) {
  if (!option.empty()) return option;
  for (const char* key : keys) {
    const auto it = r.header.find(key);
    if (it != r.header.end() && !it->second.empty()) return it->second;
  }
  return fallback;
}

/// The option if finite, else the first header value that is a number, else 99999 (unknown).
double number_or_header(double option, const VectorRecord& r, std::initializer_list<const char*> keys) {
  if (std::isfinite(option)) return option;
  for (const char* key : keys) {
    const auto it = r.header.find(key);
    if (it == r.header.end()) continue;
    char* end = nullptr;
    const double v = std::strtod(it->second.c_str(), &end);
    if (end != it->second.c_str() && *end == '\0' && std::isfinite(v)) return v;
  }
  return kFill;
}

CdfWriteVariable data_variable(const std::string& name, const std::string& fieldnam, const std::string& units,
                               double valid_min, double valid_max, const std::string& depend_0,
                               const std::string& label, std::vector<double> values) {
  CdfWriteVariable v;
  v.name = name;
  v.values = std::move(values);
  v.attributes = {{"FIELDNAM", CdfWriteEntry::of_text(fieldnam)},
                  {"UNITS", CdfWriteEntry::of_text(units)},
                  {"FILLVAL", CdfWriteEntry::of_number(kFill)},
                  {"VALIDMIN", CdfWriteEntry::of_number(valid_min)},
                  {"VALIDMAX", CdfWriteEntry::of_number(valid_max)},
                  {"DEPEND_0", CdfWriteEntry::of_text(depend_0)},
                  {"DISPLAY_TYPE", CdfWriteEntry::of_text("time_series")},
                  {"LABLAXIS", CdfWriteEntry::of_text(label)}};
  return v;
}

}  // namespace

void write_imagcdf(const std::string& path, const VectorRecord& record, const ImagCdfWriteOptions& options) {
  if (record.empty()) throw InputError(path, "ImagCDF: no samples to write");
  std::string elements;
  for (const std::string& c : record.components) {
    if (c.size() != 1 || !std::isalpha(static_cast<unsigned char>(c[0]))) {
      throw InputError(path, "ImagCDF: component '" + c + "' is not a one-letter element code (X, Y, Z, H, E, D, ...)");
    }
    elements += static_cast<char>(std::toupper(static_cast<unsigned char>(c[0])));
  }
  std::vector<std::int64_t> times;
  times.reserve(record.size());
  for (std::size_t i = 0; i < record.size(); ++i) {
    const double t = record.time_s[i];
    if (!std::isfinite(t) || tai_minus_utc_s(t) < 0) {
      throw InputError(path, "ImagCDF: sample " + std::to_string(i) + " at " + time_for_message(t) +
                                 " is before 1972 (TT2000 with leap seconds starts there)");
    }
    times.push_back(unix_to_tt2000(t));
    if (i > 0 && times[i] <= times[i - 1]) {
      throw InputError(path, "ImagCDF: sample " + std::to_string(i) + " at " + time_for_message(t) +
                                 " is not after the previous one");
    }
  }
  CdfWriteContent content;
  content.big_endian = options.big_endian;
  content.gzip_variables = options.gzip;
  std::string iaga = header_value(record, options.iaga_code, {"IagaCode", "StationIAGAcode"}, record.station);
  for (char& c : iaga) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  double publication = options.publication_date_s;
  if (!std::isfinite(publication)) {
    publication = std::floor(std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count());
  }
  auto text = [](std::string t) { return std::vector<CdfWriteEntry>{CdfWriteEntry::of_text(std::move(t))}; };
  auto number = [](double v) { return std::vector<CdfWriteEntry>{CdfWriteEntry::of_number(v)}; };
  content.global = {
      {"FormatDescription", text("INTERMAGNET CDF Format")},
      {"FormatVersion", text("1.2")},
      {"Title", text("Geomagnetic time series data")},
      {"IagaCode", text(iaga.empty() ? "XXX" : iaga)},
      {"ElementsRecorded", text(elements)},
      {"PublicationLevel", text(header_value(record, options.publication_level, {}, "2"))},
      {"PublicationDate", {CdfWriteEntry::of_time(unix_to_tt2000(publication))}},
      {"ObservatoryName", text(header_value(record, options.observatory_name, {"ObservatoryName", "StationName"}, iaga))},
      {"Latitude", number(number_or_header(options.latitude, record, {"Latitude", "StationLatitude"}))},
      {"Longitude", number(number_or_header(options.longitude, record, {"Longitude", "StationLongitude"}))},
      {"Elevation", number(number_or_header(options.elevation, record, {"Elevation", "StationElevation"}))},
      {"Institution", text(header_value(record, options.institution, {"Institution", "StationInstitution"}, "unknown"))},
      {"VectorSensOrient", text(options.vector_sens_orient.empty() ? elements : options.vector_sens_orient)},
      {"StandardLevel", text("None")},
      {"Source", text(options.source.empty() ? "institute" : options.source)},
  };
  const std::string terms = header_value(record, options.terms_of_use, {"TermsOfUse", "DataTerms"}, "");
  if (!terms.empty()) content.global.push_back({"TermsOfUse", text(terms)});
  if (!options.comments.empty()) {
    std::vector<CdfWriteEntry> comments;
    for (const std::string& c : options.comments) comments.push_back(CdfWriteEntry::of_text(c));
    content.global.push_back({"Comments", comments});
  }

  for (int c = 0; c < 3; ++c) {
    std::vector<double> values(record.size());
    for (std::size_t i = 0; i < record.size(); ++i) {
      const double v = record.values_nT(static_cast<Eigen::Index>(i), c);
      if (std::isfinite(v) && std::abs(v) > kValidField) {
        char b[160];
        std::snprintf(b, sizeof b, "ImagCDF: %s = %.3f nT at %s is outside VALIDMIN..VALIDMAX (+-79999 nT)",
                      record.components[static_cast<std::size_t>(c)].c_str(), v, time_for_message(record.time_s[i]).c_str());
        throw InputError(path, b);
      }
      values[i] = std::isfinite(v) ? v : kFill;
    }
    const std::string e(1, elements[static_cast<std::size_t>(c)]);
    content.variables.push_back(data_variable("GeomagneticField" + e, "Geomagnetic Field Element " + e, "nT",
                                              -kValidField, kValidField, "GeomagneticVectorTimes", e, std::move(values)));
  }
  CdfWriteVariable vector_times;
  vector_times.name = "GeomagneticVectorTimes";
  vector_times.data_type = kCdfTimeTt2000;
  vector_times.times = times;
  content.variables.push_back(vector_times);
  for (std::size_t k = 0; k < record.auxiliary.size(); ++k) {
    const AuxiliaryChannel& a = record.auxiliary[k];
    if (a.values.size() != record.size()) {
      throw InputError(path, "ImagCDF: auxiliary channel " + a.name + " has " + std::to_string(a.values.size()) +
                                 " values for " + std::to_string(record.size()) + " samples");
    }
    const std::string name = "Temperature" + std::to_string(k + 1);
    std::vector<double> values(a.values);
    for (double& v : values) v = std::isfinite(v) && v >= -273.15 && v <= 1000.0 ? v : kFill;
    content.variables.push_back(data_variable(name, a.description.empty() ? a.name : a.description, "Celsius", -273.15,
                                              1000.0, name + "Times", name, std::move(values)));
    CdfWriteVariable t = vector_times;
    t.name = name + "Times";
    content.variables.push_back(std::move(t));
  }
  write_cdf(path, content);
}

}  // namespace magnetometer_insitu_calibration
