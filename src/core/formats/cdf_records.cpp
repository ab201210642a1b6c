// MagPy CDF and ImagCDF layouts -> VectorRecord; see cdf_records.hpp.
#include "magnetometer_insitu_calibration/formats/cdf_records.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/cdf_epoch.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <limits>

namespace magnetometer_insitu_calibration {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string variable_list(const CdfFile& file) {
  std::string out;
  for (const CdfVariable& v : file.variables()) out += (out.empty() ? "" : ", ") + v.name;
  return out.empty() ? "none" : out;
}

std::string text_attribute(const CdfVariable& v, const std::string& name) {
  const auto it = v.attributes.find(name);
  return it != v.attributes.end() && it->second.is_text() ? it->second.text : std::string();
}

const CdfVariable& need_variable(const CdfFile& file, const std::string& name, const std::string& layout) {
  const CdfVariable* v = file.find(name);
  if (v == nullptr) {
    throw InputError(file.name(), layout + ": variable " + name + " missing (variables: " + variable_list(file) + ")");
  }
  return *v;
}

/// Times of a time variable as UNIX seconds; NaN for a fill time or one inside a leap second.
std::vector<double> unix_times(const CdfFile& file, const CdfVariable& v) {
  std::vector<double> out;
  if (v.values_per_record != 1 || v.num_elems != 1) {
    throw InputError(file.name(), "CDF time variable " + v.name + ": not one time per record");
  }
  if (v.data_type == kCdfTimeTt2000) {
    for (std::int64_t t : file.read_int64(v)) {
      double unix_s = kNaN;
      const Tt2000Status status = tt2000_to_unix(t, unix_s);
      if (status == Tt2000Status::kBefore1972 || status == Tt2000Status::kTooLate) {
        throw InputError(file.name(), "CDF time variable " + v.name + " record " + std::to_string(out.size()) +
                                          ": TT2000 " + std::to_string(t) + " is outside 1972 to 2262 (not supported)");
      }
      out.push_back(status == Tt2000Status::kOk ? unix_s : kNaN);
    }
  } else if (v.data_type == kCdfEpoch || v.data_type == kCdfEpoch16) {
    const std::vector<double> raw = file.read_real(v);
    for (double e : raw) {
      // EPOCH: ms since year 0; EPOCH16: its seconds part (picoseconds are below our resolution).
      const double unix_s = v.data_type == kCdfEpoch ? cdf_epoch_to_unix(e) : e - kCdfEpochUnixOffset_s;
      out.push_back(std::isfinite(e) && e > 0 ? unix_s : kNaN);  // fill -1e31, pad 0
    }
  } else {
    throw InputError(file.name(), "CDF time variable " + v.name + ": data type " + std::to_string(v.data_type) +
                                      " is not CDF_TIME_TT2000, CDF_EPOCH or CDF_EPOCH16");
  }
  return out;
}

/// A numeric variable's values, one per record; FILLVAL, out-of-range and infinite values as NaN.
std::vector<double> field_values(const CdfFile& file, const CdfVariable& v) {
  if (v.values_per_record != 1 || v.num_elems != 1) {
    throw InputError(file.name(), "CDF variable " + v.name + ": not one value per record");
  }
  std::vector<double> values = file.read_real(v);
  double fill = kNaN, low = -std::numeric_limits<double>::infinity(), high = std::numeric_limits<double>::infinity();
  auto number = [&](const char* name, double& out) {
    const auto it = v.attributes.find(name);
    if (it != v.attributes.end() && !it->second.numbers.empty()) out = it->second.numbers[0];
  };
  number("FILLVAL", fill);
  number("VALIDMIN", low);
  number("VALIDMAX", high);
  for (double& x : values) {
    if (!std::isfinite(x) || x == fill || x < low || x > high) x = kNaN;
  }
  return values;
}

struct Layout {
  std::string name;                       ///< "MagPy CDF", "ImagCDF"
  std::string time_variable;
  std::array<std::string, 3> field;       ///< variable names
  std::array<std::string, 3> components;
  std::vector<std::string> temperatures;  ///< variable names
};

std::string depend_0(const CdfFile& file, const std::string& variable) {
  const CdfVariable* v = file.find(variable);
  return v ? text_attribute(*v, "DEPEND_0") : std::string();
}

Layout magpy_layout(const CdfFile& file) {
  Layout l;
  l.name = "MagPy CDF";
  l.field = {"x", "y", "z"};
  for (const std::string& f : l.field) need_variable(file, f, l.name);
  l.time_variable = depend_0(file, "x");
  if (l.time_variable.empty()) l.time_variable = file.find("time") ? "time" : "Epoch";
  std::string letters = file.global_text("DataComponents");
  l.components = {"X", "Y", "Z"};
  if (letters.size() >= 3) {
    for (int i = 0; i < 3; ++i) l.components[i] = std::string(1, static_cast<char>(std::toupper(static_cast<unsigned char>(letters[i]))));
  }
  for (const char* t : {"t1", "t2"}) {
    if (file.find(t)) l.temperatures.push_back(t);
  }
  return l;
}

Layout imagcdf_layout(const CdfFile& file) {
  Layout l;
  l.name = "ImagCDF";
  std::string elements = file.global_text("ElementsRecorded");
  std::vector<std::string> vector_elements;
  for (char c : elements) {
    const char e = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    if (e != 'F' && e != 'S' && e != 'G' && std::isalpha(static_cast<unsigned char>(e))) vector_elements.push_back(std::string(1, e));
  }
  if (elements.empty()) {  // no ElementsRecorded: the field variables in file order
    for (const CdfVariable& v : file.variables()) {
      const std::string prefix = "GeomagneticField";
      if (v.name.size() == prefix.size() + 1 && v.name.compare(0, prefix.size(), prefix) == 0 &&
          std::string("FSG").find(v.name.back()) == std::string::npos) {
        vector_elements.push_back(v.name.substr(prefix.size()));
      }
    }
  }
  if (vector_elements.size() < 3) {
    throw InputError(file.name(), "ImagCDF: ElementsRecorded '" + elements + "' has fewer than three vector elements (variables: " +
                                      variable_list(file) + ")");
  }
  for (int i = 0; i < 3; ++i) {
    l.components[i] = vector_elements[static_cast<std::size_t>(i)];
    l.field[i] = "GeomagneticField" + l.components[i];
    const CdfVariable& v = need_variable(file, l.field[i], l.name);
    std::string units = text_attribute(v, "UNITS");
    for (char& c : units) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (l.components[i] == "D" || l.components[i] == "I" || units.find("deg") != std::string::npos) {
      throw InputError(file.name(), "ImagCDF: element " + l.components[i] + " of ElementsRecorded '" + elements +
                                        "' is an angle, not a field component in nT (X, Y, Z, H, E, V are read)");
    }
  }
  l.time_variable = depend_0(file, l.field[0]);
  if (l.time_variable.empty()) l.time_variable = file.find("GeomagneticVectorTimes") ? "GeomagneticVectorTimes" : "DataTimes";
  for (int i = 1; i < 3; ++i) {
    const std::string other = depend_0(file, l.field[i]);
    if (!other.empty() && other != l.time_variable) {
      throw InputError(file.name(), "ImagCDF: " + l.field[i] + " has times " + other + ", " + l.field[0] + " has " +
                                        l.time_variable + " (vector elements on different times are not supported)");
    }
  }
  for (const CdfVariable& v : file.variables()) {
    if (v.name.compare(0, 11, "Temperature") == 0 && v.name.find("Times") == std::string::npos) l.temperatures.push_back(v.name);
  }
  return l;
}

/// Values on `from` times, linearly interpolated to `to` times (both increasing where finite).
std::vector<double> interpolate(const std::vector<double>& from, const std::vector<double>& values,
                                const std::vector<double>& to) {
  std::vector<double> out(to.size(), kNaN);
  std::size_t j = 0;
  for (std::size_t i = 0; i < to.size(); ++i) {
    while (j + 1 < from.size() && !(from[j + 1] > to[i])) ++j;
    if (j >= from.size() || from[j] > to[i]) continue;
    if (from[j] == to[i]) {
      out[i] = values[j];
    } else if (j + 1 < from.size()) {
      const double w = (to[i] - from[j]) / (from[j + 1] - from[j]);
      out[i] = values[j] + w * (values[j + 1] - values[j]);  // NaN if either side is missing
    }
  }
  return out;
}

}  // namespace

VectorRecord cdf_to_vector_record(const CdfFile& file) {
  const bool imag = std::any_of(file.variables().begin(), file.variables().end(), [](const CdfVariable& v) {
    return v.name.compare(0, 16, "GeomagneticField") == 0;
  });
  const bool magpy = file.find("x") || file.global_text("DataFormat").compare(0, 5, "MagPy") == 0;
  if (!imag && !magpy) {
    throw InputError(file.name(), "CDF file is neither MagPy CDF (variables x, y, z) nor ImagCDF (GeomagneticField<E>); "
                                  "variables: " + variable_list(file));
  }
  const Layout layout = imag ? imagcdf_layout(file) : magpy_layout(file);
  const CdfVariable& time_variable = need_variable(file, layout.time_variable, layout.name);
  const std::vector<double> times = unix_times(file, time_variable);

  VectorRecord r;
  r.source = file.name();
  r.components = layout.components;
  for (const auto& [name, entries] : file.global_attributes()) r.header[name] = file.global_text(name);
  r.header["cdf_layout"] = layout.name;
  r.station = file.global_text(imag ? "IagaCode" : "StationIAGAcode");
  if (r.station.empty() && !imag) r.station = file.global_text("StationID");

  std::array<std::vector<double>, 3> field;
  for (int c = 0; c < 3; ++c) {
    field[c] = field_values(file, need_variable(file, layout.field[c], layout.name));
    field[c].resize(times.size(), kNaN);  // a variable with fewer records than its times: missing
  }
  struct Channel {
    AuxiliaryChannel channel;
    std::vector<double> values;  ///< on `times`
  };
  std::vector<Channel> channels;
  for (const std::string& name : layout.temperatures) {
    const CdfVariable& v = need_variable(file, name, layout.name);
    Channel ch;
    ch.channel.name = name;
    ch.channel.description = text_attribute(v, "FIELDNAM");
    ch.channel.unit = text_attribute(v, "UNITS");
    if (ch.channel.unit.empty()) ch.channel.unit = "degC";
    ch.values = field_values(file, v);
    const std::string own_times = text_attribute(v, "DEPEND_0");
    if (!own_times.empty() && own_times != layout.time_variable) {
      const std::vector<double> t = unix_times(file, need_variable(file, own_times, layout.name));
      ch.values.resize(t.size(), kNaN);
      ch.values = interpolate(t, ch.values, times);
    }
    ch.values.resize(times.size(), kNaN);
    channels.push_back(std::move(ch));
  }
  if (!imag) {  // MagPy: the column names and units of t1, t2 (ColumnContents/ColumnUnits, 5th and 6th)
    const std::string contents = file.global_text("ColumnContents"), units = file.global_text("ColumnUnits");
    auto item = [](const std::string& list, std::size_t k) {
      std::size_t start = 0;
      for (std::size_t i = 0; i < k && start != std::string::npos; ++i) {
        start = list.find(',', start);
        if (start != std::string::npos) ++start;
      }
      if (start == std::string::npos) return std::string();
      return list.substr(start, list.find(',', start) - start);
    };
    for (Channel& ch : channels) {
      const std::size_t k = ch.channel.name == "t1" ? 4 : 5;
      if (ch.channel.description.empty()) ch.channel.description = item(contents, k);
      const std::string unit = item(units, k);
      if (!unit.empty()) ch.channel.unit = unit == "deg_C" ? "degC" : unit;
    }
  }

  std::size_t kept = 0, dropped = 0;
  for (std::size_t i = 0; i < times.size(); ++i) kept += std::isfinite(times[i]);
  dropped = times.size() - kept;
  r.time_s.reserve(kept);
  r.values_nT.resize(static_cast<Eigen::Index>(kept), 3);
  for (Channel& ch : channels) ch.channel.values.reserve(kept);
  for (std::size_t i = 0; i < times.size(); ++i) {
    if (!std::isfinite(times[i])) continue;
    if (!r.time_s.empty() && !(times[i] > r.time_s.back())) {
      throw InputError(file.name(), layout.name + ": time variable " + layout.time_variable + " record " +
                                        std::to_string(i) + " is not after the previous record");
    }
    const auto row = static_cast<Eigen::Index>(r.time_s.size());
    for (int c = 0; c < 3; ++c) r.values_nT(row, c) = field[c][i];
    r.time_s.push_back(times[i]);
    for (Channel& ch : channels) ch.channel.values.push_back(ch.values[i]);
  }
  if (r.time_s.empty()) throw InputError(file.name(), layout.name + ": no record with a valid time");
  r.header["cdf_records_dropped"] = std::to_string(dropped);
  for (Channel& ch : channels) r.auxiliary.push_back(std::move(ch.channel));
  return r;
}

VectorRecord read_cdf_record(const std::string& path) { return cdf_to_vector_record(CdfFile::open(path)); }

}  // namespace magnetometer_insitu_calibration
