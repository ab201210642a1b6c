// IAGA-2002 writing; see iaga2002.hpp for the layout and the rules (reading: iaga2002.cpp).
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/common/time_steps.hpp"
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"
#include "iaga2002_text.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace magnetometer_insitu_calibration {

using namespace iaga2002_detail;

namespace {

/// Printable ASCII only: tabs become spaces, other bytes '?'.
std::string ascii(const std::string& text) {
  std::string out = text;
  for (char& c : out) {
    if (c == '\t') c = ' ';
    else if (c < 0x20 || c > 0x7e) c = '?';
  }
  return out;
}

std::string pad(const std::string& text, std::size_t width) {
  return text.size() >= width ? text : text + std::string(width - text.size(), ' ');
}

/// Greedy word wrap of one line of text into pieces of at most `width` characters.
std::vector<std::string> wrap_words(const std::string& text, std::size_t width) {
  std::vector<std::string> lines;
  std::string current;
  for (std::string word : split_blanks(text)) {
    while (word.size() > width) {  // a word longer than a record is cut
      if (!current.empty()) {
        lines.push_back(current);
        current.clear();
      }
      lines.push_back(word.substr(0, width));
      word.erase(0, width);
    }
    if (word.empty()) continue;
    if (current.empty()) {
      current = word;
    } else if (current.size() + 1 + word.size() <= width) {
      current += " " + word;
    } else {
      lines.push_back(current);
      current = word;
    }
  }
  if (!current.empty() || lines.empty()) lines.push_back(current);
  return lines;
}

std::string default_interval_type(const std::vector<double>& times) {
  if (times.size() < 2) return std::string();
  const double step_s = std::round(median_time_step(times) * 1e6) / 1e6;  // to the microsecond
  if (std::fabs(step_s - 1.0) < 1e-6) return "1-second";
  if (std::fabs(step_s - 60.0) < 1e-6) return "1-minute";
  if (std::fabs(step_s - 3600.0) < 1e-6) return "1-hour";
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g-second", step_s);
  return buffer;
}

/// A header value: the option, else the record's header field `key` (any case), else `fallback`.
std::string header_value(const VectorRecord& record, const std::string& option, const std::string& key,
                         const std::string& fallback) {
  if (!option.empty()) return option;
  if (const std::string* value = find_header(record.header, key)) {
    if (!value->empty()) return *value;
  }
  return fallback;
}

/// The header records' labels and values, in the order of the format.
std::vector<std::pair<std::string, std::string>> header_fields(const VectorRecord& record,
                                                               const Iaga2002WriteOptions& options,
                                                               const std::string& iaga_code) {
  auto pick = [&](const std::string& option, const std::string& key, const std::string& fallback) {
    return header_value(record, option, key, fallback);
  };
  std::string component_letters;
  for (const std::string& name : record.components) component_letters += name;
  return {
      {"Format", "IAGA-2002"},
      {"Source of Data", pick(options.source_of_data, "Source of Data", "unknown")},
      {"Station Name", pick(options.station_name, "Station Name", record.station)},
      {"IAGA Code", iaga_code},
      {"Geodetic Latitude", pick(options.geodetic_latitude, "Geodetic Latitude", "")},
      {"Geodetic Longitude", pick(options.geodetic_longitude, "Geodetic Longitude", "")},
      {"Elevation", pick(options.elevation, "Elevation", "")},
      {"Reported", pick(options.reported, "Reported", component_letters + "F")},
      {"Sensor Orientation", pick(options.sensor_orientation, "Sensor Orientation",
                                  component_letters)},
      {"Digital Sampling", pick(options.digital_sampling, "Digital Sampling", "")},
      {"Data Interval Type", pick(options.data_interval_type, "Data Interval Type",
                                  default_interval_type(record.time_s))},
      {"Data Type", pick(options.data_type, "Data Type", "variation")},
  };
}

/// Appends the header records, then the comment records (each '\n'-separated line of a comment
/// word-wrapped to the comment width).
void append_header_and_comments(std::string& text, const std::string& path,
                                const std::vector<std::pair<std::string, std::string>>& fields,
                                const std::vector<std::string>& comments) {
  for (const auto& field : fields) {
    const std::string value = ascii(trim_blanks(field.second));
    if (value.size() > kValueWidth) {
      throw InputError(path, "header field '" + field.first + "' is " +
                                 std::to_string(value.size()) + " characters long; at most " +
                                 std::to_string(kValueWidth) + " fit in IAGA-2002");
    }
    text += " " + pad(field.first, kLabelWidth) + pad(value, kValueWidth) + "|\r\n";
  }
  for (const std::string& paragraph : comments) {
    std::size_t start = 0;
    for (;;) {  // each '\n'-separated line of the paragraph is wrapped separately
      const std::size_t end = paragraph.find('\n', start);
      const std::string piece = ascii(paragraph.substr(start, end == std::string::npos
                                                                  ? std::string::npos
                                                                  : end - start));
      for (const std::string& wrapped : wrap_words(piece, kCommentWidth)) {
        text += " # " + pad(wrapped, kCommentWidth) + "|\r\n";
      }
      if (end == std::string::npos) break;
      start = end + 1;
    }
  }
}

/// The column header record: names (IAGA code + component) start in columns 33, 43, 53 and 63.
std::string column_header(const std::string& path, const VectorRecord& record, const std::string& iaga_code) {
  std::array<std::string, 4> columns;
  for (std::size_t i = 0; i < 3; ++i) {
    const std::string& component = record.components[i];
    if (component.empty() || component.find_first_of(" \t|") != std::string::npos) {
      throw InputError(path, "component name '" + component +
                                 "' is empty or contains a blank or '|'");
    }
    columns[i] = iaga_code + ascii(component);
  }
  columns[3] = iaga_code + "F";
  for (std::size_t i = 0; i < 4; ++i) {
    if (columns[i].size() > (i < 3 ? 9u : 7u)) {
      throw InputError(path, "column name '" + columns[i] + "' (IAGA code + component) is " +
                                 "too long for the IAGA-2002 column header");
    }
  }
  return "DATE       TIME         DOY     " + pad(columns[0], 10) + pad(columns[1], 10) +
         pad(columns[2], 10) + pad(columns[3], 7) + "|\r\n";
}

/// Appends data record r: "yyyy-mm-dd hh:mm:ss.sss ddd" + 3 blanks + 4 values of 10 characters
/// (nT, F not recorded). `previous_stamp`: the previous record's ISO 8601 time ("" before the
/// first), replaced by this one's.
void append_data_record(std::string& text, const std::string& path, const VectorRecord& record, std::size_t r,
                        std::string& previous_stamp) {
  char line[128];
  std::string stamp;
  try {
    stamp = format_iso8601(record.time_s[r], 3);  // "2025-05-14T00:00:00.000Z"
  } catch (const std::invalid_argument& error) {
    throw InputError(path, "sample " + std::to_string(r) + ": " + error.what());
  }
  if (!previous_stamp.empty() && !(stamp > previous_stamp)) {  // fixed width: text order
    throw InputError(path, "sample " + std::to_string(r) + " at " + stamp +
                               " is not after the previous sample at " + previous_stamp +
                               " (IAGA-2002 times have millisecond resolution)");
  }
  const std::int64_t year = std::stoi(stamp.substr(0, 4));
  const int month = std::stoi(stamp.substr(5, 2));
  const int day = std::stoi(stamp.substr(8, 2));
  const int doy = static_cast<int>(days_from_civil(year, month, day) -
                                   days_from_civil(year, 1, 1) + 1);
  int length = std::snprintf(line, sizeof line, "%.10s %.12s %03d   ", stamp.c_str(),
                             stamp.c_str() + 11, doy);
  std::string data(line, static_cast<std::size_t>(length));
  for (int c = 0; c < 3; ++c) {
    const double value = record.values_nT(static_cast<Eigen::Index>(r), c);
    if (std::isnan(value)) {
      data += kMissing;
      continue;
    }
    // Values that round to 88888.00 or more would read back as missing.
    if (!(value < kIagaMissingFrom_nT - 0.005 && value > -999999.995)) {
      throw InputError(path, "sample " + std::to_string(r) + " at " + stamp + ", component " +
                                 record.components[c] + ": " + std::to_string(value) +
                                 " nT cannot be written in IAGA-2002 (must be between "
                                 "-999999.99 and 88887.99, or NaN)");
    }
    length = std::snprintf(line, sizeof line, "%10.2f", value);
    data.append(line, static_cast<std::size_t>(length));
  }
  data += kNotRecorded;
  text += data;
  text += "\r\n";
  previous_stamp = std::move(stamp);
}

}  // namespace

void write_iaga2002(const std::string& path, const VectorRecord& record,
                    const Iaga2002WriteOptions& options) {
  const std::size_t n = record.size();
  if (n == 0) throw InputError(path, "cannot write an empty record (IAGA-2002 needs data lines)");
  if (record.values_nT.rows() != static_cast<Eigen::Index>(n)) {
    throw InputError(path, "record has " + std::to_string(n) + " times but " +
                               std::to_string(record.values_nT.rows()) + " rows of values");
  }
  const std::string iaga_code = upper(
      !options.iaga_code.empty() ? options.iaga_code
                                 : (!record.station.empty() ? record.station
                                                            : header_value(record, "", "IAGA Code", "")));
  std::string text;
  text.reserve((n + 40) * (kRecordWidth + 2));
  append_header_and_comments(text, path, header_fields(record, options, iaga_code), options.comments);
  text += column_header(path, record, iaga_code);
  std::string previous_stamp;
  for (std::size_t r = 0; r < n; ++r) append_data_record(text, path, record, r, previous_stamp);

  TextFileWriter writer(path);
  writer.write(text);
  writer.close();
}

}  // namespace magnetometer_insitu_calibration
