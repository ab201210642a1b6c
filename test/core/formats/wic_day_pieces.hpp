// Pieces of the real WIC day (data/wic20250514_lemi036.sec.gz: IAGA-2002, 1 s, station WIC,
// components H, E, Z) as the files a follower of daily files meets: a day cut at any line, a last
// line still being written, a line with another stamp, another station or sample period.
#pragma once

#include "test_support.hpp"

#include <cstddef>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration::test {

/// The file's lines without line ends: its 19 header records, then its 86400 data records.
struct IagaDay {
  std::vector<std::string> header;
  std::vector<std::string> data;
};

inline const IagaDay& wic_day() {
  static const IagaDay day = [] {
    IagaDay d;
    for (const std::string& line : read_lines(package_data("wic20250514_lemi036.sec.gz"))) {
      (line.compare(0, 4, "2025") == 0 ? d.data : d.header).push_back(line);
    }
    return d;
  }();
  return day;
}

/// UNIX seconds of data record k (2025-05-14T00:00:00Z + k s).
inline double wic_time_s(std::size_t k) { return 1747180800.0 + static_cast<double>(k); }

/// Data record k with the stamp (date, time and day of year: the first 27 characters) of record j.
inline std::string wic_line_stamped(std::size_t k, std::size_t j) {
  return wic_day().data[j].substr(0, 27) + wic_day().data[k].substr(27);
}

/// The header, then `lines`, each ending in CRLF, then `partial` without a line end (a record
/// being written). With `station`, the header's and the column header's code "WIC" replaced.
inline std::string iaga_text(const std::vector<std::string>& lines, const std::string& partial = "",
                             const std::string& station = "WIC") {
  std::string text;
  for (std::string line : wic_day().header) {
    for (std::size_t at = line.find("WIC"); at != std::string::npos; at = line.find("WIC", at + 3)) {
      line.replace(at, 3, station);
    }
    text += line + "\r\n";
  }
  for (const std::string& line : lines) text += line + "\r\n";
  return text + partial;
}

/// Data records [first, last) of the day, every `step`-th.
inline std::vector<std::string> wic_lines(std::size_t first, std::size_t last, std::size_t step = 1) {
  std::vector<std::string> lines;
  for (std::size_t k = first; k < last; k += step) lines.push_back(wic_day().data[k]);
  return lines;
}

}  // namespace magnetometer_insitu_calibration::test
