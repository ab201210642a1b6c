// Delimited-text records; see csv_record.hpp.
#include "magnetometer_insitu_calibration/formats/csv_record.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <vector>

namespace magnetometer_insitu_calibration {

namespace {

constexpr std::size_t kColumns = 4;  // time and three components; more: auxiliary

/// Unit of an auxiliary column, from its name: temperatures are in deg C, others unknown.
std::string auxiliary_unit(const std::string& name) {
  std::string lower;
  for (char c : name) lower += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower.find("temperature") != std::string::npos ? "degC" : "";
}

char choose_delimiter(const std::string& line) {
  std::size_t commas = 0;
  std::size_t semicolons = 0;
  std::size_t tabs = 0;
  for (char c : line) {
    if (c == ',') ++commas;
    else if (c == ';') ++semicolons;
    else if (c == '\t') ++tabs;
  }
  if (semicolons > commas && semicolons >= tabs) return ';';
  if (tabs > commas && tabs > semicolons) return '\t';
  return ',';
}

std::vector<std::string> split_fields(const std::string& line, char delimiter) {
  std::vector<std::string> fields;
  std::size_t start = 0;
  for (;;) {
    const std::size_t end = line.find(delimiter, start);
    std::string field =
        trim_blanks(line.substr(start, end == std::string::npos ? std::string::npos : end - start));
    if (field.size() >= 2 && field.front() == '"' && field.back() == '"') {
      field = trim_blanks(field.substr(1, field.size() - 2));
    }
    fields.push_back(field);
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return fields;
}

bool is_nan_text(const std::string& text) {
  return text.size() == 3 && (text[0] == 'n' || text[0] == 'N') &&
         (text[1] == 'a' || text[1] == 'A') && (text[2] == 'n' || text[2] == 'N');
}

/// Time field to UNIX seconds; false with `why` set if it is neither a number nor ISO 8601.
bool parse_time_field(const std::string& text, double& time_s, std::string& why) {
  if (text.empty()) {
    why = "empty";
    return false;
  }
  if (parse_number(text, time_s)) {
    if (std::isfinite(time_s)) return true;
    why = "'" + text + "' is not a finite time";
    return false;
  }
  try {
    time_s = parse_iso8601(text);
    return true;
  } catch (const std::invalid_argument& error) {
    why = "'" + text + "' is neither UNIX seconds nor an ISO 8601 UTC time (" + error.what() + ")";
    return false;
  }
}

bool looks_like_header(const std::vector<std::string>& fields) {
  double time_s = 0.0;
  std::string why;
  if (parse_time_field(fields[0], time_s, why)) return false;
  // A data line with a bad time still has numbers in the value columns: report it as data.
  for (std::size_t i = 1; i < fields.size(); ++i) {
    double value = 0.0;
    if (!fields[i].empty() && !is_nan_text(fields[i]) && !parse_number(fields[i], value)) {
      return true;
    }
  }
  return false;
}

}  // namespace

VectorRecord read_csv_record(const std::string& path, const TextReadOptions& options) {
  TextLineReader reader(path, options);
  VectorRecord record;
  record.source = path;
  std::vector<std::string> names{"time", "X", "Y", "Z"};  // then the auxiliary columns, if a header names them
  std::string comments;
  bool have_comments = false;
  char delimiter = 0;  // chosen from the first content line
  std::vector<double> times;
  std::vector<std::array<double, 3>> rows;
  std::vector<std::vector<double>> auxiliary;  // one per column after the fourth
  std::size_t previous_line = 0;
  std::string previous_data_line;  // the last line that gave a sample

  auto column = [&](std::size_t i) {
    return "column " + std::to_string(i + 1) + " (" + names[i] + ")";
  };

  std::string line;
  while (reader.next(line)) {
    const std::size_t n = reader.line_number();
    const std::size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos) continue;
    if (line[first] == '#') {
      if (have_comments) comments += '\n';
      comments += trim_blanks(line.substr(first + 1));
      have_comments = true;
      continue;
    }
    if (drop_cut_last_line(reader, line, previous_data_line, record.header)) continue;
    try {
      const bool first_content = delimiter == 0;
      if (first_content) delimiter = choose_delimiter(line);
      const std::vector<std::string> fields = split_fields(line, delimiter);
      const bool header = first_content && fields.size() >= kColumns && looks_like_header(fields);
      if (header) {
        names.clear();
        for (std::size_t i = 0; i < fields.size(); ++i) {
          if (fields[i].empty()) {
            throw InputError(path, n, "header: column " + std::to_string(i + 1) + " has no name");
          }
          for (std::size_t j = kColumns; j < i; ++j) {
            if (names[j] == fields[i]) throw InputError(path, n, "header: column name '" + fields[i] + "' repeated");
          }
          names.push_back(fields[i]);
        }
        for (std::size_t i = 0; i < 3; ++i) record.components[i] = names[i + 1];
        auxiliary.assign(names.size() - kColumns, {});
        continue;
      }
      if (fields.size() != names.size()) {
        std::string expected = names[0];
        for (std::size_t i = 1; i < names.size(); ++i) expected += delimiter + names[i];
        throw InputError(path, n,
                         "expected " + std::to_string(names.size()) + " columns (" + expected + "), found " +
                             std::to_string(fields.size()) +
                             (fields.size() > names.size() && names.size() == kColumns
                                  ? "; columns after the fourth (e.g. a temperature) need a header line "
                                    "naming them, e.g. time,X,Y,Z,temperature"
                                  : ""));
      }

      double time_s = 0.0;
      std::string why;
      if (!parse_time_field(fields[0], time_s, why)) throw InputError(path, n, column(0) + ": " + why);
      std::array<double, 3> row{};
      for (std::size_t i = 1; i < kColumns; ++i) {
        const std::string& text = fields[i];
        double value = std::numeric_limits<double>::quiet_NaN();
        if (!text.empty() && !is_nan_text(text)) {
          if (!parse_number(text, value) || std::isinf(value)) {
            throw InputError(path, n, column(i) + ": '" + text + "' is not a number");
          }
          if (value >= kIagaMissingFrom_nT) value = std::numeric_limits<double>::quiet_NaN();
        }
        row[i - 1] = value;
      }
      for (std::size_t i = kColumns; i < fields.size(); ++i) {
        const std::string& text = fields[i];
        double value = std::numeric_limits<double>::quiet_NaN();  // empty or "nan": missing
        if (!text.empty() && !is_nan_text(text) && (!parse_number(text, value) || std::isinf(value))) {
          throw InputError(path, n, column(i) + ": '" + text + "' is not a number");
        }
        auxiliary[i - kColumns].push_back(value);
      }
      if (skip_line_out_of_order(reader, time_s, times, record.header)) {  // TextReadOptions::skip_out_of_order
        for (auto& channel : auxiliary) channel.resize(times.size());
        previous_data_line = line;
        continue;
      }
      if (!times.empty() && !(time_s > times.back())) {
        throw InputError(path, n,
                         column(0) + ": " +
                             (time_s == times.back() ? "duplicate time " : "time goes backwards: ") +
                             time_for_message(time_s) + " is not after " +
                             time_for_message(times.back()) + " on line " +
                             std::to_string(previous_line));
      }
      times.push_back(time_s);
      rows.push_back(row);
      previous_line = n;
      previous_data_line = line;
    } catch (const InputError& error) {
      if (!drop_partial_last_line(reader, error, !times.empty(), record.header)) throw;
      for (auto& channel : auxiliary) channel.resize(times.size());  // nothing of the refused line kept
    }
  }

  note_held_last_line(reader, record.header);
  // A file still being written may have no data line yet (complete_lines_only): an empty record.
  if (times.empty() && !reader.options().complete_lines_only) throw InputError(path, "no data lines");
  if (have_comments) record.header["comments"] = comments;
  record.time_s = std::move(times);
  record.values_nT.resize(static_cast<Eigen::Index>(rows.size()), 3);
  for (std::size_t r = 0; r < rows.size(); ++r) {
    for (int c = 0; c < 3; ++c) record.values_nT(static_cast<Eigen::Index>(r), c) = rows[r][c];
  }
  for (std::size_t i = 0; i < auxiliary.size(); ++i) {
    const std::string& name = names[kColumns + i];
    record.auxiliary.push_back({name, "", auxiliary_unit(name), std::move(auxiliary[i])});
  }
  return record;
}

namespace {

/// Fewest decimals in {3, 6, 9} with which every time reads back exactly (9 if none does).
int iso_decimals(const std::vector<double>& times) {
  for (int decimals : {3, 6}) {
    bool exact = true;
    for (double t : times) {
      if (parse_iso8601(format_iso8601(t, decimals)) != t) {
        exact = false;
        break;
      }
    }
    if (exact) return decimals;
  }
  return 9;
}

std::string shortest_number(double value) {
  char buffer[64];
  const std::to_chars_result result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

}  // namespace

void write_csv_record(const std::string& path, const VectorRecord& record, bool iso_time,
                      int decimals) {
  const std::size_t n = record.size();
  if (n == 0) throw InputError(path, "cannot write an empty record (no data lines)");
  if (record.values_nT.rows() != static_cast<Eigen::Index>(n)) {
    throw InputError(path, "record has " + std::to_string(n) + " times but " +
                               std::to_string(record.values_nT.rows()) + " rows of values");
  }
  if (decimals < 0 || decimals > 17) {
    throw InputError(path, "decimals " + std::to_string(decimals) + " outside 0..17");
  }
  for (std::size_t r = 0; r < n; ++r) {
    const double t = record.time_s[r];
    if (!std::isfinite(t)) throw InputError(path, "sample " + std::to_string(r) + ": time not finite");
    if (r > 0 && !(t > record.time_s[r - 1])) {
      throw InputError(path, "sample " + std::to_string(r) + ": time " + shortest_number(t) +
                                 " s is not after the previous one");
    }
  }

  std::string text;
  text.reserve((n + 8) * 64);
  auto comment_it = record.header.find("comments");
  if (comment_it != record.header.end() && !comment_it->second.empty()) {
    std::size_t start = 0;
    for (;;) {
      const std::size_t end = comment_it->second.find('\n', start);
      text += "# " + comment_it->second.substr(start, end == std::string::npos ? std::string::npos
                                                                                : end - start) +
              "\n";
      if (end == std::string::npos) break;
      start = end + 1;
    }
  }
  text += "time";
  for (const std::string& name : record.components) {
    double number = 0.0;
    if (name.empty() || name.find_first_of(",;\t\"\r\n") != std::string::npos ||
        parse_number(trim_blanks(name), number) || trim_blanks(name) != name) {
      throw InputError(path, "component name '" + name +
                                 "' is empty, a number, or has a delimiter, quote, newline or "
                                 "surrounding blanks");
    }
    text += "," + name;
  }
  for (const AuxiliaryChannel& a : record.auxiliary) {
    double number = 0.0;
    if (a.name.empty() || a.name.find_first_of(",;\t\"\r\n") != std::string::npos ||
        parse_number(trim_blanks(a.name), number) || trim_blanks(a.name) != a.name) {
      throw InputError(path, "auxiliary channel name '" + a.name +
                                 "' is empty, a number, or has a delimiter, quote, newline or surrounding blanks");
    }
    if (a.values.size() != n) {
      throw InputError(path, "auxiliary channel " + a.name + " has " + std::to_string(a.values.size()) +
                                 " values for " + std::to_string(n) + " samples");
    }
    text += "," + a.name;
  }
  text += "\n";

  const int time_decimals = iso_time ? iso_decimals(record.time_s) : 0;
  char buffer[64];
  for (std::size_t r = 0; r < n; ++r) {
    const double t = record.time_s[r];
    try {
        text += iso_time ? format_iso8601(t, time_decimals) : shortest_number(t);
      } catch (const std::invalid_argument& error) {
        throw InputError(path, "sample " + std::to_string(r) + ": " + error.what());
      }
      for (int c = 0; c < 3; ++c) {
        const double value = record.values_nT(static_cast<Eigen::Index>(r), c);
        text += ',';
        if (std::isnan(value)) {
          text += "nan";
          continue;
        }
        const int length = std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
        double back = 0.0;
        if (std::isinf(value) || length <= 0 || length >= static_cast<int>(sizeof buffer) ||
            !parse_number(std::string(buffer, static_cast<std::size_t>(length)), back) ||
            back >= kIagaMissingFrom_nT) {
          throw InputError(path, "sample " + std::to_string(r) + ", component " +
                                     record.components[c] + ": value " + std::to_string(value) +
                                     " nT cannot be written (infinite, or would read back as "
                                     "missing: >= 88888)");
        }
        text.append(buffer, static_cast<std::size_t>(length));
      }
      for (const AuxiliaryChannel& a : record.auxiliary) {
        const double value = a.values[r];
        if (std::isinf(value)) {
          throw InputError(path, "sample " + std::to_string(r) + ", " + a.name + ": value is infinite");
        }
        text += ',';
        text += std::isnan(value) ? std::string("nan") : shortest_number(value);
      }
      text += '\n';
    }

    TextFileWriter writer(path);
    writer.write(text);
    writer.close();
  }

  }  // namespace magnetometer_insitu_calibration
