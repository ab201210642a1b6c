// IAGA-2002 exchange format (geomagnetic observatory data): reading and writing VectorRecords.
// Layout: 12 mandatory header records and optional comment records (space in column 1, '|' in
// column 70), one column-header record "DATE TIME DOY <4 elements>", then data records
// "yyyy-mm-dd hh:mm:ss.sss ddd" + 4 values in nT; every record 70 characters.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"  // TextReadOptions

#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// IAGA-2002's missing-value convention: a value of 88888 nT or more (88888.00 "not recorded",
/// 99999.00 "missing") is not a reading. The CSV reader follows it too.
constexpr double kIagaMissingFrom_nT = 88888.0;

/// Reads an IAGA-2002 file, plain or gzip-compressed (detected from the content).
/// - components: the first three element columns of the column header, the station code
///   removed ("WICH WICE WICZ WICF" with IAGA code WIC -> "H", "E", "Z"); the 4th (F or G)
///   column is checked for a number and ignored.
/// - station: the "IAGA Code" header field; source: `path`.
/// - header: every header record, key and value trimmed ("Data Interval Type" -> "1-second");
///   the comment records' text, joined by '\n', under "comments".
/// - values >= 88888 (88888.00 "not recorded", 99999.00 "missing") become NaN.
/// Throws InputError(path, line, problem) naming the field for: a malformed number or date,
/// a DOY that does not match the date, too few or too many columns, a time not after the previous
/// one; InputError(path, problem) for a missing file, a missing column header or no data line.
/// `options`: a file still being written, a clock that steps (text_lines.hpp).
VectorRecord read_iaga2002(const std::string& path, const TextReadOptions& options = TextReadOptions());

/// Header values for write_iaga2002. Each field left empty takes the record's header value of
/// the same name (as read_iaga2002 stores them), and otherwise the default given here.
/// Every value must fit in 45 characters.
struct Iaga2002WriteOptions {
  std::string source_of_data;      ///< "Source of Data"; default "unknown"
  std::string station_name;        ///< "Station Name"; default record.station
  std::string iaga_code;           ///< "IAGA Code"; default record.station, upper case
  std::string geodetic_latitude;   ///< degrees north, e.g. "47.930"; default blank
  std::string geodetic_longitude;  ///< degrees east, 0..360, e.g. "15.865"; default blank
  std::string elevation;           ///< metres above sea level; default blank
  std::string reported;            ///< default: the components' names + "F", e.g. "HEZF"
  std::string sensor_orientation;  ///< default: the components' names, e.g. "HEZ"
  std::string digital_sampling;    ///< e.g. "0.1 second"; default blank
  std::string data_interval_type;  ///< default from the median sample spacing: "1-second", ...
  std::string data_type;           ///< default "variation"
  /// Comment records, in order. Each string is one paragraph, word-wrapped into records of at
  /// most 66 characters of text; a '\n' inside a string starts a new record.
  std::vector<std::string> comments;
};

/// Writes `record` in IAGA-2002 layout: every line exactly 70 characters plus CRLF; the 12
/// mandatory header records, the comment records, the column header (IAGA code + component
/// name, then code + "F"), and one data record per sample with time rounded to the millisecond,
/// values "%10.2f" in nT, NaN written as 99999.00 and the F column as 88888.00.
/// gzip-compressed when `path` ends in ".gz". Nothing is written if the record cannot be:
/// throws InputError(path, problem) for an empty record, a header value too long, a column name
/// longer than 7 characters, times not strictly increasing at millisecond resolution, or a value
/// that does not fit (>= 88888 nT would read back as missing; <= -1e6 nT overflows the field).
void write_iaga2002(const std::string& path, const VectorRecord& record,
                    const Iaga2002WriteOptions& options = Iaga2002WriteOptions());

}  // namespace magnetometer_insitu_calibration
