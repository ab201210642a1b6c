// Archived records for the bag and export tools (ROS-free): every record format read without
// giving up at the first damaged record, LEMI temperatures, the correction into the reference
// frame, and the calibration of a calibrate_records JSON report.
#pragma once

#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <nlohmann/json.hpp>

#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// Instrument temperatures, where the format has them (LEMI-025: one pair per packet, i.e. per
/// second; stamped with the time of the packet's first reading, shift included). deg C.
struct RecordTemperatures {
  std::vector<double> time_s;         ///< UNIX s, strictly increasing
  std::vector<double> sensor_C;       ///< sensor (fluxgate) temperature
  std::vector<double> electronics_C;  ///< electronics temperature
  bool empty() const { return time_s.empty(); }
  std::size_t size() const { return time_s.size(); }
};

struct ArchiveReadOptions {
  LemiReadOptions lemi;  ///< LEMI formats: field mode, time shift, checksum
  /// Text formats after a damaged line: lines parsed per block (the block of a damaged line is
  /// read again, so a smaller block costs less per damaged line and more per block).
  std::size_t first_block_lines = 8192;
  std::size_t max_block_lines = 1u << 20;
  /// Called with the fraction done (0..1) while a damaged text file is read block by block.
  std::function<void(double)> progress;
};

/// A record as read from an archive file, with what was skipped.
struct ArchiveRecord {
  VectorRecord record;
  RecordFormat format = RecordFormat::kCsv;
  RecordTemperatures temperatures;
  /// One message per damaged record, skipped run of bytes or out-of-order sample, each naming
  /// its position: "<path>:<line>: ..." (text) or "<path> byte <offset>: ..." (LEMI); a text
  /// file's last line dropped, cut short (read_record's warning), is one too, not counted skipped.
  std::vector<std::string> problems;
  /// Records skipped: damaged lines and out-of-order samples (text); damaged records, skipped
  /// byte runs and dropped readings (LEMI: one per reader warning).
  std::size_t skipped = 0;
};

/// Reads any format of record_file.hpp. A text file that the strict reader accepts is returned
/// exactly as read_record returns it. When a data line is damaged (a malformed number, date or
/// DOY, a wrong number of columns, a time not after the previous one), the line is reported
/// with its number and skipped, and the rest of the file is read: the good lines are parsed by
/// the same strict reader, block by block (header records repeated), so every good sample has
/// exactly the value it would have in a clean file. Samples out of time order are resolved by
/// keeping the longest strictly increasing run of samples (earliest lines first on ties): a
/// single sample stamped in the future costs that sample only. LEMI files keep the readers'
/// behaviour (resynchronisation, warnings with byte offsets) and add the temperatures.
/// Throws InputError for a file that cannot be read at all (missing, no header, no good record).
ArchiveRecord read_archive_record(const std::string& path, const ArchiveReadOptions& options = {});

/// Several files of one instrument (daily files) as one record: parts in time order, the records
/// joined by join_records (record_join.hpp: samples overlapping an earlier file dropped, one
/// message per part in `problems`), temperatures joined the same way, problems and skipped
/// counts added up. One part is returned as it is. (archive_join.cpp)
ArchiveRecord join_archive_records(std::vector<ArchiveRecord> parts);

/// read_archive_record for each path, then join_archive_records. (archive_join.cpp)
ArchiveRecord read_archive_records(const std::vector<std::string>& paths, const ArchiveReadOptions& options = {});

/// Test readings corrected into the reference frame: rows r = t n^-1 (T = R n, rows are samples),
/// NaN rows stay NaN. Times, source, station and header are kept; components are `components`.
/// Offsets are not touched: a test baseline b (T = R n + b) appears as b n^-1 in the result.
/// Throws InputError("calibration", ...) when n is not finite or its condition number is above
/// max_condition.
VectorRecord correct_record(const VectorRecord& test, const Eigen::Matrix3d& n,
                            const std::array<std::string, 3>& components, double max_condition = 100.0);

/// One window of a calibrate_records JSON report.
struct ReportWindow {
  std::size_t index = 0;   ///< 0-based position in "windows"
  std::string label;       ///< "interval 2/4", "whole record", "window 7"
  std::string start, end;  ///< ISO 8601 UTC
  Eigen::Matrix3d n = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d n_stderr = Eigen::Matrix3d::Zero();
  std::string quality;     ///< "ok", ...
  nlohmann::json json;     ///< the whole window object
};

/// Picks a window of a calibrate_records --json report: `which` is a 1-based index ("3"), a
/// label ("whole record", "interval 2/4"), or empty: the "whole record" window if there is one,
/// else the last window whose quality is "ok". Throws InputError(path, ...) naming what is
/// missing (no such window, no matrix, a null entry).
ReportWindow select_report_window(const nlohmann::json& report, const std::string& which, const std::string& path);

/// Reads and parses a JSON file; throws InputError(path, ...).
nlohmann::json read_json_file(const std::string& path);

}  // namespace magnetometer_insitu_calibration
