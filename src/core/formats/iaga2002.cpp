// IAGA-2002 reading; see iaga2002.hpp for the layout and the rules (writing: iaga2002_writer.cpp).
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "iaga2002_text.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace magnetometer_insitu_calibration {

using namespace iaga2002_detail;

namespace {

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
                     std::size_t& previous_line, const TextLineReader& reader,
                     std::map<std::string, std::string>& header) {
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

  if (skip_line_out_of_order(reader, time_s, times, header)) {  // TextReadOptions::skip_out_of_order
    if (fourth.size() > times.size()) fourth.pop_back();
    return;
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

VectorRecord read_iaga2002(const std::string& path, const TextReadOptions& options) {
  TextLineReader reader(path, options);
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
        parse_data_line(path, n, line, layout, times, rows, fourth, previous_line, reader, record.header);
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

  note_held_last_line(reader, record.header);
  // A file still being written may have no data line yet (complete_lines_only): an empty record.
  const bool being_written = options.complete_lines_only && (have_columns || reader.last_line_held());
  if (!have_columns && !being_written) {
    throw InputError(path, "no column header 'DATE TIME DOY ...': not an IAGA-2002 file?");
  }
  if (times.empty() && !being_written) throw InputError(path, "no data lines after the column header");
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

}  // namespace magnetometer_insitu_calibration
