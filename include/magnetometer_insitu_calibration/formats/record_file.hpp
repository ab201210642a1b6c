// Reading a record file whatever its format, recognised from the content.
#pragma once

#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"  // TextReadOptions
#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

enum class RecordFormat {
  kIaga2002,
  kCsv,
  kLemiBin,           ///< LemiBin (lemi_archive.hpp)
  kLemiCompactFlash,  ///< LEMI-025 compact-flash card image
  kLemi025Stream,     ///< raw capture of the LEMI-025 serial byte stream
  kCdf,               ///< NASA CDF: MagPy CDF or ImagCDF (cdf_records.hpp)
};

/// "IAGA-2002", "CSV", "LemiBin", "LEMI compact flash", "LEMI-025 byte stream", "CDF".
const char* record_format_name(RecordFormat format);

/// CDF first, from its magic number: 0xCDF30001 (CDF 3.x) or 0xCDF26002 (CDF 2.6/2.7) in bytes 0-3,
/// whatever follows (0x0000FFFF, or 0xCCCC0001 for a compressed file); also 0x0000FFFF twice (CDF
/// before 2.6, which read_record then refuses by name).
/// Binary LEMI files next, from the first 64 KiB of raw bytes (a gzip file is text):
///  - "LemiBin" at byte 0, or two valid LEMI-025 packets 169 bytes apart: LemiBin;
///  - two valid packets 153 bytes apart: raw byte stream;
///  - a valid compact-flash caption (tag + BCD time) at the start of the first 512-byte block
///    that is not erased: compact flash;
///  - one valid packet anywhere: raw byte stream (a short capture).
/// Otherwise text: the first non-blank line (plain or gzip) starting with "Format" after blanks
/// (IAGA-2002 has " Format" in column 1) and containing "IAGA-2002" (any case) marks an
/// IAGA-2002 file; anything else, including an empty file, is taken as CSV.
/// Throws InputError(path, "cannot open: ...") for a missing file.
RecordFormat detect_record_format(const std::string& path);

/// detect_record_format, then read_iaga2002, read_csv_record, read_lemi_bin,
/// read_lemi_compact_flash, read_lemi025_stream (LEMI: default LemiReadOptions, full field) or
/// read_cdf_record.
VectorRecord read_record(const std::string& path);

/// The same with LEMI read options; the readers' warnings go to *warnings when given: the LEMI
/// readers' damaged records skipped, each with its byte offset; the text readers' last line
/// dropped, cut short in a file still being written (text_lines.hpp, "<file>:<line>: last line
/// dropped ..."). Any other bad text line throws InputError(path:line, ...).
/// `text_options` go to the text readers (a file still being written, a clock that steps:
/// text_lines.hpp); the binary formats' readers do not take them.
VectorRecord read_record(const std::string& path, const LemiReadOptions& lemi_options,
                         std::vector<std::string>* warnings, const TextReadOptions& text_options = TextReadOptions());

}  // namespace magnetometer_insitu_calibration
