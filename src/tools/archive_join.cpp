// Several archive files of one instrument as one ArchiveRecord; see archive_records.hpp.
#include "archive_records.hpp"

#include "magnetometer_insitu_calibration/formats/record_join.hpp"

#include <algorithm>
#include <limits>

namespace magnetometer_insitu_calibration {

ArchiveRecord join_archive_records(std::vector<ArchiveRecord> parts) {
  if (parts.size() == 1) return std::move(parts.front());
  auto first_time = [](const ArchiveRecord& a) {
    return a.record.empty() ? std::numeric_limits<double>::infinity() : a.record.time_s.front();
  };
  std::stable_sort(parts.begin(), parts.end(),
                   [&](const ArchiveRecord& a, const ArchiveRecord& b) { return first_time(a) < first_time(b); });
  ArchiveRecord out;
  if (!parts.empty()) out.format = parts.front().format;
  std::vector<VectorRecord> records;
  for (ArchiveRecord& p : parts) {
    out.problems.insert(out.problems.end(), p.problems.begin(), p.problems.end());
    out.skipped += p.skipped;
    for (std::size_t i = 0; i < p.temperatures.size(); ++i) {  // in time order, overlaps dropped
      const double t = p.temperatures.time_s[i];
      if (!out.temperatures.empty() && !(t > out.temperatures.time_s.back())) continue;
      out.temperatures.time_s.push_back(t);
      out.temperatures.sensor_C.push_back(p.temperatures.sensor_C[i]);
      out.temperatures.electronics_C.push_back(p.temperatures.electronics_C[i]);
    }
    records.push_back(std::move(p.record));
  }
  out.record = join_records(std::move(records), &out.problems);
  return out;
}

ArchiveRecord read_archive_records(const std::vector<std::string>& paths, const ArchiveReadOptions& options) {
  std::vector<ArchiveRecord> parts;
  for (const std::string& path : paths) parts.push_back(read_archive_record(path, options));
  return join_archive_records(std::move(parts));
}

}  // namespace magnetometer_insitu_calibration
