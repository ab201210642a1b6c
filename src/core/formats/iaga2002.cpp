// IAGA-2002 reading and writing; see iaga2002.hpp for the layout and the rules.
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/time_steps.hpp"
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace magnetometer_insitu_calibration {

namespace {

constexpr std::size_t kRecordWidth = 70;     // characters per record, without CRLF
constexpr std::size_t kLabelWidth = 23;      // header label in columns 2..24
constexpr std::size_t kValueWidth = 45;      // header value in columns 25..69
constexpr std::size_t kCommentWidth = 66;    // comment text in columns 4..69
constexpr const char* kMissing = "  99999.00";
constexpr const char* kNotRecorded = "  88888.00";

std::vector<std::string> split_blanks(const std::string& line) {
  std::vector<std::string> tokens;
  std::size_t pos = 0;
  while (pos < line.size()) {
    while (pos < line.size() && (line[pos] == ' ' || line[pos] == '\t')) ++pos;
    if (pos >= line.size()) break;
    std::size_t end = pos;
    while (end < line.size() && line[end] != ' ' && line[end] != '\t') ++end;
    tokens.push_back(line.substr(pos, end - pos));
    pos = end;
  }
  return tokens;
}

std::string upper(std::string text) {
  for (char& c : text) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return text;
}

bool equal_ignoring_case(const std::string& a, const std::string& b) { return upper(a) == upper(b); }

/// Header or comment record content: without the leading space, the trailing '|' and blanks.
std::string record_content(const std::string& line) {
  std::string content = line.substr(1);
  const std::size_t last = content.find_last_not_of(" \t");
  if (last == std::string::npos) return std::string();
  content.erase(last + 1);
  if (content.back() == '|') content.pop_back();
  return content;
}

/// Splits a header record's content into label and value: the label ends at the first run of
/// two blanks (labels are words separated by single spaces), or else at column 24.
void split_header(const std::string& content, std::string& key, std::string& value) {
  const std::string trimmed = trim_blanks(content);
  const std::size_t gap = trimmed.find("  ");
  if (gap != std::string::npos) {
    key = trim_blanks(trimmed.substr(0, gap));
    value = trim_blanks(trimmed.substr(gap));
  } else if (content.size() > kLabelWidth) {
    key = trim_blanks(content.substr(0, kLabelWidth));
    value = trim_blanks(content.substr(kLabelWidth));
  } else {
    key = trimmed;
    value.clear();
  }
}

const std::string* find_header(const std::map<std::string, std::string>& header,
                               const std::string& key) {
  for (const auto& entry : header) {
    if (equal_ignoring_case(entry.first, key)) return &entry.second;
  }
  return nullptr;
}

int day_of_year(std::int64_t days_since_epoch) {
  std::int64_t year = 0;
  int month = 0;
  int day = 0;
  civil_from_days(days_since_epoch, year, month, day);
  return static_cast<int>(days_since_epoch - days_from_civil(year, 1, 1) + 1);
}

struct ColumnLayout {
  std::vector<std::string> names;  // element column names as in the file, e.g. "WICH"
};

ColumnLayout parse_column_header(const std::string& path, std::size_t line_number,
                                 const std::string& line) {
  std::vector<std::string> tokens = split_blanks(line);
  if (!tokens.empty() && tokens.back() == "|") tokens.pop_back();
  if (!tokens.empty() && tokens.back().size() > 1 && tokens.back().back() == '|') {
    tokens.back().pop_back();
  }
  if (tokens.size() < 3 || tokens[0] != "DATE" || tokens[1] != "TIME" || tokens[2] != "DOY") {
    throw InputError(path, line_number,
                     "column header: expected 'DATE TIME DOY' followed by the element names");
  }
  ColumnLayout layout;
  layout.names.assign(tokens.begin() + 3, tokens.end());
  if (layout.names.size() < 3 || layout.names.size() > 4) {
    throw InputError(path, line_number,
                     "column header: expected 4 element columns (e.g. WICH WICE WICZ WICF), found " +
                         std::to_string(layout.names.size()));
  }
  return layout;
}

std::string component_from_column(const std::string& column, const std::string& station) {
  if (!station.empty() && column.size() > station.size() &&
      equal_ignoring_case(column.substr(0, station.size()), station)) {
    return column.substr(station.size());
  }
  return column;
}

/// Parses one data record, appending its time and values; throws naming the field.
void parse_data_line(const std::string& path, std::size_t line_number, const std::string& line,
                     const ColumnLayout& layout, std::vector<double>& times,
                     std::vector<std::array<double, 3>>& rows, std::vector<double>& fourth,
                     std::size_t& previous_line) {
  const std::vector<std::string> tokens = split_blanks(line);
  const std::size_t expected = 3 + layout.names.size();
  if (tokens.size() != expected) {
    std::string columns = "DATE TIME DOY";
    for (const std::string& name : layout.names) columns += " " + name;
    throw InputError(path, line_number,
                     std::string(tokens.size() < expected ? "too few" : "too many") +
                         " columns: expected " + std::to_string(expected) + " (" + columns +
                         "), found " + std::to_string(tokens.size()));
  }

  double time_s = 0.0;
  try {
    if (tokens[0].size() != 10) throw std::invalid_argument("DATE must be yyyy-mm-dd");
    time_s = parse_iso8601(tokens[0] + " " + tokens[1]);
  } catch (const std::invalid_argument& error) {
    throw InputError(path, line_number,
                     "DATE/TIME field '" + tokens[0] + " " + tokens[1] + "': " + error.what());
  }

  const std::string& doy_text = tokens[2];
  const std::int64_t days = static_cast<std::int64_t>(std::floor(time_s / 86400.0));
  const int doy_expected = day_of_year(days);
  int doy = 0;
  bool doy_ok = !doy_text.empty() && doy_text.size() <= 3;
  for (char c : doy_text) {
    if (c < '0' || c > '9') doy_ok = false;
    if (doy_ok) doy = doy * 10 + (c - '0');  // at most 3 digits: no int overflow
  }
  if (!doy_ok) {
    throw InputError(path, line_number, "DOY field: '" + doy_text + "' is not a day of year");
  }
  if (doy != doy_expected) {
    throw InputError(path, line_number,
                     "DOY field: " + doy_text + " does not match the date " + tokens[0] +
                         " (day of year " + std::to_string(doy_expected) + ")");
  }

  std::array<double, 3> row{};
  for (std::size_t i = 0; i < layout.names.size(); ++i) {
    const std::string& text = tokens[3 + i];
    double value = 0.0;
    if (!parse_number(text, value) || std::isinf(value)) {
      throw InputError(path, line_number,
                       layout.names[i] + " field: '" + text + "' is not a number");
    }
    if (std::isnan(value) || value >= kIagaMissingFrom_nT) {
      value = std::numeric_limits<double>::quiet_NaN();
    }
    if (i < 3) row[i] = value;  // the 4th (F or G) column is not part of the vector
    if (i == 3) fourth.push_back(value);
  }

  if (!times.empty() && !(time_s > times.back())) {
    throw InputError(path, line_number,
                     std::string("DATE/TIME field: ") +
                         (time_s == times.back() ? "duplicate time " : "time goes backwards: ") +
                         time_for_message(time_s) + " is not after " + time_for_message(times.back()) +
                         " on line " + std::to_string(previous_line));
  }
  times.push_back(time_s);
  rows.push_back(row);
  previous_line = line_number;
}

}  // namespace

VectorRecord read_iaga2002(const std::string& path) {
  TextLineReader reader(path);
  VectorRecord record;
  record.source = path;
  std::vector<std::string> comments;
  ColumnLayout layout;
  bool have_columns = false;
  std::vector<double> times;
  std::vector<std::array<double, 3>> rows;
  std::vector<double> fourth;  // the F (or G) column
  std::size_t previous_line = 0;
  std::string previous_data_line;  // the last line that gave a sample

  std::string line;
  while (reader.next(line)) {
    const std::size_t n = reader.line_number();
    if (line.find_first_not_of(" \t") == std::string::npos) continue;  // blank line
    if (have_columns) {
      if (drop_cut_last_line(reader, line, previous_data_line, record.header)) continue;
      try {
        parse_data_line(path, n, line, layout, times, rows, fourth, previous_line);
        previous_data_line = line;
      } catch (const InputError& error) {
        if (!drop_partial_last_line(reader, error, !times.empty(), record.header)) throw;
        if (fourth.size() > times.size()) fourth.resize(times.size());  // nothing of the refused line kept
      }
      continue;
    }
    if (line.compare(0, 4, "DATE") == 0) {
      layout = parse_column_header(path, n, line);
      have_columns = true;
      if (const std::string* code = find_header(record.header, "IAGA Code")) record.station = *code;
      for (std::size_t i = 0; i < 3; ++i) {
        record.components[i] = component_from_column(layout.names[i], record.station);
      }
      continue;
    }
    if (line[0] != ' ') {
      throw InputError(path, n,
                       "expected a header record (a space in column 1) or the column header "
                       "'DATE TIME DOY ...'");
    }
    const std::string content = record_content(line);
    const std::string trimmed = trim_blanks(content);
    if (!trimmed.empty() && trimmed[0] == '#') {
      comments.push_back(trim_blanks(trimmed.substr(1)));
      continue;
    }
    std::string key;
    std::string value;
    split_header(content, key, value);
    if (!key.empty()) record.header[key] = value;
  }

  if (!have_columns) {
    throw InputError(path, "no column header 'DATE TIME DOY ...': not an IAGA-2002 file?");
  }
  if (times.empty()) throw InputError(path, "no data lines after the column header");
  if (!comments.empty()) {
    std::string joined;
    for (std::size_t i = 0; i < comments.size(); ++i) {
      if (i > 0) joined += '\n';
      joined += comments[i];
    }
    record.header["comments"] = joined;
  }

  record.time_s = std::move(times);
  record.values_nT.resize(static_cast<Eigen::Index>(rows.size()), 3);
  for (std::size_t r = 0; r < rows.size(); ++r) {
    for (int c = 0; c < 3; ++c) record.values_nT(static_cast<Eigen::Index>(r), c) = rows[r][c];
  }
  // A recorded F (the observatory's scalar magnetometer, when the fourth column is F): an
  // auxiliary channel, read by the scalar check (formats/scalar_record.hpp).
  const std::string& fourth_name = layout.names.size() > 3 ? layout.names[3] : std::string();
  if (!fourth_name.empty() && fourth_name.back() == 'F' && fourth.size() == record.time_s.size() &&
      std::any_of(fourth.begin(), fourth.end(), [](double v) { return std::isfinite(v); })) {
    record.auxiliary.push_back({"F", "scalar field", "nT", std::move(fourth)});
  }
  return record;
}

// ---------------------------------------------------------------------------------------------
// Writing

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
