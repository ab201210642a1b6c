// Line-by-line text input and output, plain or gzip-compressed, through zlib.
#pragma once

#include <cstddef>
#include <limits>
#include <map>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// How the text readers (IAGA-2002, CSV) read a file that may still be written and whose clock
/// may step, as a follower of daily files reads them (record_follower.hpp). The defaults are the
/// strict rules of every program (below: a cut last line dropped, any other bad line refuses the
/// file).
struct TextReadOptions {
  /// A last line without a line end is not read at all, nor the rest of a gzip stream cut
  /// short: it is still being written. The reader notes it under kHeldLastLineKey.
  bool complete_lines_only = false;
  /// A data line whose time is not after the last sample kept (a clock stepped back, a repeated
  /// line) or is after `latest_time_s` (a clock stepped ahead) is skipped and counted under
  /// kLinesBackwardsKey or kLinesAheadKey, the first such line described under
  /// kFirstSkippedLineKey, instead of refusing the file.
  bool skip_out_of_order = false;
  double latest_time_s = std::numeric_limits<double>::infinity();  ///< UNIX s
};

/// Streams the lines of a plain or gzip text file (zlib detects which from the content).
/// Lines are returned without the line end: "\n" and the "\r" of "\r\n" are removed.
/// A last line without a line end is still returned; a UTF-8 byte-order mark at the start of
/// the first line is removed. Not copyable.
class TextLineReader {
 public:
  /// Throws InputError(path, "cannot open: <strerror>") when the file cannot be opened.
  /// `options` are the reader's (complete_lines_only applies here; the helpers below read the rest).
  explicit TextLineReader(const std::string& path, const TextReadOptions& options = TextReadOptions());
  ~TextLineReader();
  TextLineReader(const TextLineReader&) = delete;
  TextLineReader& operator=(const TextLineReader&) = delete;

  /// Reads the next line into `line`; false at the end of the file (line then empty).
  /// Throws InputError(path:line, ...) on a read or decompression error.
  bool next(std::string& line);
  /// 1-based number of the line last returned by next(); 0 before the first.
  std::size_t line_number() const { return line_number_; }
  /// True when the line last returned is the file's last and has no line end: a file still
  /// being written (today's daily file at a station) ends so, cut within a record.
  bool last_line_unterminated() const { return unterminated_; }
  /// With complete_lines_only: true when next() stopped before a last line without a line end
  /// (or a gzip stream cut short), which it did not return.
  bool last_line_held() const { return held_; }
  const std::string& path() const { return path_; }
  const TextReadOptions& options() const { return options_; }

 private:
  std::string path_;
  TextReadOptions options_;
  bool held_ = false;
  void* file_ = nullptr;  // gzFile, kept opaque so that users need not include zlib.h
  std::size_t line_number_ = 0;
  bool at_end_ = false;
  bool unterminated_ = false;
};

class InputError;

/// The header key under which a text reader notes a last line it dropped: its value is the
/// warning, "<file>:<line>: last line dropped (the lines before it are kept): it ends the file
/// without a line end (a file still being written?) and <why>". read_record passes it on.
inline constexpr const char* kPartialLastLineKey = "partial_last_line";

// The one rule of the text readers (IAGA-2002, CSV) for a file's last line without a line end, a
// record still being written and cut within a line: such a line is dropped with the warning above
// when it does not parse, or when it parses but is cut short (drop_cut_last_line); the good lines
// before it are kept. Any other line that does not parse refuses the file.

/// Called by a text reader before it parses the data line `line`, with the data line it parsed
/// before (empty for none): when `line` is the file's last, has no line end, is shorter than the
/// line before and its last field has fewer decimals than that line's (a number cut within its
/// digits, which would parse to a wrong value), it is noted in `header` and true returned (the
/// caller skips it); otherwise false.
bool drop_cut_last_line(const TextLineReader& reader, const std::string& line, const std::string& previous_line,
                        std::map<std::string, std::string>& header);

/// Called by a text reader whose data line failed to parse with `error`: when that line is the
/// file's last, has no line end and the record already has data (`have_data`), it is dropped,
/// noted in `header`, and true returned; otherwise false (the caller rethrows: a damaged line
/// refuses the file).
bool drop_partial_last_line(const TextLineReader& reader, const InputError& error, bool have_data,
                            std::map<std::string, std::string>& header);

/// Header keys under which a text reader notes what TextReadOptions made it do: the last line
/// held ("<file>:<line>: last line not read: it has no line end yet"), the counts of lines
/// skipped (decimal text) and the first of them ("<file>:<line>: time ... is not after ...").
inline constexpr const char* kHeldLastLineKey = "held_last_line";
inline constexpr const char* kLinesBackwardsKey = "lines_skipped_backwards";
inline constexpr const char* kLinesAheadKey = "lines_skipped_ahead";
inline constexpr const char* kFirstSkippedLineKey = "first_line_skipped";

/// Called by a text reader with a data line's time before it keeps the line, `times` the times
/// kept so far: with skip_out_of_order, when the time is not after times.back() or is after
/// latest_time_s, the line is counted and noted in `header` and true returned (the caller skips
/// it); otherwise false (the caller applies its own rule: a time not after the one before
/// refuses the file).
bool skip_line_out_of_order(const TextLineReader& reader, double time_s, const std::vector<double>& times,
                            std::map<std::string, std::string>& header);

/// Called by a text reader at the end of the file: notes a held last line under kHeldLastLineKey.
void note_held_last_line(const TextLineReader& reader, std::map<std::string, std::string>& header);

/// The count a reader noted under `key` (kLinesBackwardsKey, kLinesAheadKey); 0 when none.
std::size_t noted_count(const std::map<std::string, std::string>& header, const char* key);

/// Writes text to a file, gzip-compressed when the path ends in ".gz", plain otherwise.
/// The destructor closes the file but cannot report errors: call close().
class TextFileWriter {
 public:
  /// Throws InputError(path, "cannot create: <strerror>").
  explicit TextFileWriter(const std::string& path);
  ~TextFileWriter();
  TextFileWriter(const TextFileWriter&) = delete;
  TextFileWriter& operator=(const TextFileWriter&) = delete;

  /// Appends text exactly as given (the caller writes its own line ends).
  /// Throws InputError(path, "write failed: ...").
  void write(const std::string& text);
  /// Flushes and closes; throws InputError(path, "write failed: ...") if anything was lost.
  void close();
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  void* file_ = nullptr;  // gzFile
};

/// True when `path` ends in ".gz" (ASCII case-insensitive).
bool has_gz_suffix(const std::string& path);

/// `text` without leading and trailing spaces, tabs, CR and LF.
std::string trim_blanks(const std::string& text);

/// Parses the whole of `text` (no surrounding blanks) as a decimal floating-point number,
/// locale-independently ("1.5", "-2e3", "+7", "nan", "inf"). False if anything is left over.
bool parse_number(const std::string& text, double& value);

}  // namespace magnetometer_insitu_calibration
