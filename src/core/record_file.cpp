// Format detection and dispatch; see record_file.hpp.
#include "magnetometer_insitu_calibration/record_file.hpp"

#include "magnetometer_insitu_calibration/csv_record.hpp"
#include "magnetometer_insitu_calibration/iaga2002.hpp"
#include "magnetometer_insitu_calibration/text_lines.hpp"

#include <cctype>

namespace magnetometer_insitu_calibration {

namespace {

std::string upper(std::string text) {
  for (char& c : text) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return text;
}

}  // namespace

const char* record_format_name(RecordFormat format) {
  switch (format) {
    case RecordFormat::kIaga2002:
      return "IAGA-2002";
    case RecordFormat::kCsv:
      return "CSV";
  }
  return "unknown";
}

RecordFormat detect_record_format(const std::string& path) {
  TextLineReader reader(path);
  std::string line;
  while (reader.next(line)) {
    const std::string content = upper(trim_blanks(line));
    if (content.empty()) continue;
    if (content.compare(0, 6, "FORMAT") == 0 && content.find("IAGA-2002") != std::string::npos) {
      return RecordFormat::kIaga2002;
    }
    return RecordFormat::kCsv;
  }
  return RecordFormat::kCsv;
}

VectorRecord read_record(const std::string& path) {
  switch (detect_record_format(path)) {
    case RecordFormat::kIaga2002:
      return read_iaga2002(path);
    case RecordFormat::kCsv:
      break;
  }
  return read_csv_record(path);
}

}  // namespace magnetometer_insitu_calibration
