// Private to the IAGA-2002 reader and writer (iaga2002.cpp, iaga2002_writer.cpp): the record
// layout's widths and the text helpers both use.
#pragma once

#include <cctype>
#include <cstddef>
#include <map>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration::iaga2002_detail {

constexpr std::size_t kRecordWidth = 70;     // characters per record, without CRLF
constexpr std::size_t kLabelWidth = 23;      // header label in columns 2..24
constexpr std::size_t kValueWidth = 45;      // header value in columns 25..69
constexpr std::size_t kCommentWidth = 66;    // comment text in columns 4..69
constexpr const char* kMissing = "  99999.00";
constexpr const char* kNotRecorded = "  88888.00";

inline std::vector<std::string> split_blanks(const std::string& line) {
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

inline std::string upper(std::string text) {
  for (char& c : text) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return text;
}

inline bool equal_ignoring_case(const std::string& a, const std::string& b) { return upper(a) == upper(b); }

inline const std::string* find_header(const std::map<std::string, std::string>& header,
                               const std::string& key) {
  for (const auto& entry : header) {
    if (equal_ignoring_case(entry.first, key)) return &entry.second;
  }
  return nullptr;
}

}  // namespace magnetometer_insitu_calibration::iaga2002_detail
