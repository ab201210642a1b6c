// Line-by-line text input and output through zlib; see text_lines.hpp.
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include <zlib.h>

#include <cerrno>
#include <charconv>
#include <cstring>

namespace magnetometer_insitu_calibration {

namespace {

gzFile as_gz(void* file) { return static_cast<gzFile>(file); }

/// zlib's message for the last error on `file`, or strerror(errno) for a system error.
std::string gz_error_text(gzFile file) {
  int code = Z_OK;
  const char* message = gzerror(file, &code);
  if (code == Z_ERRNO) return std::strerror(errno);
  return message != nullptr ? message : "unknown zlib error";
}

}  // namespace

bool has_gz_suffix(const std::string& path) {
  if (path.size() < 3) return false;
  const std::string tail = path.substr(path.size() - 3);
  return tail[0] == '.' && (tail[1] == 'g' || tail[1] == 'G') && (tail[2] == 'z' || tail[2] == 'Z');
}

std::string trim_blanks(const std::string& text) {
  const char* blanks = " \t\r\n";
  const std::size_t first = text.find_first_not_of(blanks);
  if (first == std::string::npos) return std::string();
  const std::size_t last = text.find_last_not_of(blanks);
  return text.substr(first, last - first + 1);
}

bool parse_number(const std::string& text, double& value) {
  const char* begin = text.data();
  const char* end = begin + text.size();
  if (begin != end && *begin == '+') {  // from_chars does not take a '+' sign
    ++begin;
    if (begin != end && (*begin == '+' || *begin == '-')) return false;  // "+-1"
  }
  if (begin == end) return false;
  const std::from_chars_result result = std::from_chars(begin, end, value);
  return result.ec == std::errc() && result.ptr == end;
}

TextLineReader::TextLineReader(const std::string& path, const TextReadOptions& options)
    : path_(path), options_(options) {
  errno = 0;
  gzFile file = gzopen(path.c_str(), "rb");
  if (file == nullptr) {
    throw InputError(path, std::string("cannot open: ") +
                               (errno != 0 ? std::strerror(errno) : "out of memory"));
  }
  gzbuffer(file, 1 << 17);
  file_ = file;
}

TextLineReader::~TextLineReader() {
  if (file_ != nullptr) gzclose_r(as_gz(file_));
}

bool TextLineReader::next(std::string& line) {
  line.clear();
  if (at_end_) return false;
  char buffer[4096];
  bool got_any = false;
  for (;;) {
    errno = 0;
    if (gzgets(as_gz(file_), buffer, sizeof buffer) == nullptr) {
      at_end_ = true;
      break;
    }
    got_any = true;
    const std::size_t length = std::strlen(buffer);
    line.append(buffer, length);
    if (length > 0 && buffer[length - 1] == '\n') break;
    if (gzeof(as_gz(file_))) {
      at_end_ = true;
      break;
    }
  }
  if (at_end_) {
    // The end of the data: a real end, a read error, or a gzip stream cut short.
    int code = Z_OK;
    gzerror(as_gz(file_), &code);
    if (code == Z_BUF_ERROR) {
      if (options_.complete_lines_only) {  // a gzip file still being written: its complete lines
        held_ = true;
        line.clear();
        return false;
      }
      throw InputError(path_, line_number_ + 1, "read error: truncated gzip file");
    }
    if (code != Z_OK) {
      throw InputError(path_, line_number_ + 1, "read error: " + gz_error_text(as_gz(file_)));
    }
  }
  if (!got_any) return false;
  unterminated_ = line.empty() || line.back() != '\n';
  if (unterminated_ && options_.complete_lines_only) {  // still being written: not read
    held_ = true;
    line.clear();
    return false;
  }
  if (!line.empty() && line.back() == '\n') line.pop_back();
  if (!line.empty() && line.back() == '\r') line.pop_back();
  if (line_number_ == 0 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);  // UTF-8 BOM
  ++line_number_;
  return true;
}

namespace {

/// The warning of a dropped last line, under kPartialLastLineKey.
void note_dropped_last_line(const TextLineReader& reader, const std::string& why,
                            std::map<std::string, std::string>& header) {
  header[kPartialLastLineKey] =
      InputError(reader.path(), reader.line_number(),
                 "last line dropped (the lines before it are kept): it ends the file without a line end (a file "
                 "still being written?) and " + why)
          .what();
}

/// Digits after the '.' of the last field of `line` (fields end at blanks, commas, semicolons).
std::size_t last_field_decimals(const std::string& line) {
  const std::string text = trim_blanks(line);
  const std::size_t separator = text.find_last_of(" \t,;");
  const std::string field = separator == std::string::npos ? text : text.substr(separator + 1);
  const std::size_t dot = field.rfind('.');
  return dot == std::string::npos ? 0 : field.size() - dot - 1;
}

}  // namespace

bool drop_cut_last_line(const TextLineReader& reader, const std::string& line, const std::string& previous_line,
                        std::map<std::string, std::string>& header) {
  if (!reader.last_line_unterminated() || previous_line.empty()) return false;
  const std::size_t length = trim_blanks(line).size(), full_length = trim_blanks(previous_line).size();
  const std::size_t decimals = last_field_decimals(line), full_decimals = last_field_decimals(previous_line);
  if (!(length < full_length && decimals < full_decimals)) return false;
  note_dropped_last_line(reader,
                         "is cut short: " + std::to_string(length) + " characters, its last field " +
                             std::to_string(decimals) + " decimals, where the line before has " +
                             std::to_string(full_length) + " and " + std::to_string(full_decimals),
                         header);
  return true;
}

bool drop_partial_last_line(const TextLineReader& reader, const InputError& error, bool have_data,
                            std::map<std::string, std::string>& header) {
  if (!have_data || !reader.last_line_unterminated()) return false;
  note_dropped_last_line(reader, "does not parse: " + error.problem(), header);
  return true;
}

bool skip_line_out_of_order(const TextLineReader& reader, double time_s, const std::vector<double>& times,
                            std::map<std::string, std::string>& header) {
  const TextReadOptions& options = reader.options();
  if (!options.skip_out_of_order) return false;
  const bool backwards = !times.empty() && !(time_s > times.back());
  const bool ahead = time_s > options.latest_time_s;
  if (!backwards && !ahead) return false;
  const char* key = backwards ? kLinesBackwardsKey : kLinesAheadKey;
  header[key] = std::to_string(noted_count(header, key) + 1);
  if (header.count(kFirstSkippedLineKey) == 0) {
    header[kFirstSkippedLineKey] =
        InputError(reader.path(), reader.line_number(),
                   "line skipped: time " + time_for_message(time_s) +
                       (backwards ? " is not after " + time_for_message(times.back())
                                  : " is after " + time_for_message(options.latest_time_s) + " (ahead of the clock)"))
            .what();
  }
  return true;
}

void note_held_last_line(const TextLineReader& reader, std::map<std::string, std::string>& header) {
  if (!reader.last_line_held()) return;
  header[kHeldLastLineKey] =
      InputError(reader.path(), reader.line_number() + 1, "last line not read: it has no line end yet").what();
}

std::size_t noted_count(const std::map<std::string, std::string>& header, const char* key) {
  const auto it = header.find(key);
  return it == header.end() ? 0 : static_cast<std::size_t>(std::stoull(it->second));
}

TextFileWriter::TextFileWriter(const std::string& path) : path_(path) {
  // "T" asks zlib for plain (transparent) output.
  const char* mode = has_gz_suffix(path) ? "wb9" : "wbT";
  errno = 0;
  gzFile file = gzopen(path.c_str(), mode);
  if (file == nullptr) {
    throw InputError(path, std::string("cannot create: ") +
                               (errno != 0 ? std::strerror(errno) : "out of memory"));
  }
  gzbuffer(file, 1 << 17);
  file_ = file;
}

TextFileWriter::~TextFileWriter() {
  if (file_ != nullptr) gzclose_w(as_gz(file_));
}

void TextFileWriter::write(const std::string& text) {
  if (file_ == nullptr) throw InputError(path_, "write failed: file already closed");
  if (text.empty()) return;
  errno = 0;
  const int written = gzwrite(as_gz(file_), text.data(), static_cast<unsigned>(text.size()));
  if (written <= 0 || static_cast<std::size_t>(written) != text.size()) {
    throw InputError(path_, "write failed: " + gz_error_text(as_gz(file_)));
  }
}

void TextFileWriter::close() {
  if (file_ == nullptr) return;
  gzFile file = as_gz(file_);
  file_ = nullptr;
  errno = 0;
  const int code = gzclose_w(file);
  if (code != Z_OK) {
    throw InputError(path_, std::string("write failed: ") +
                                (code == Z_ERRNO ? std::strerror(errno) : "zlib error on close"));
  }
}

}  // namespace magnetometer_insitu_calibration
