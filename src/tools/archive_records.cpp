// Archived records read without giving up at a damaged record; see archive_records.hpp.
#include "archive_records.hpp"

#include "magnetometer_insitu_calibration/formats/csv_record.hpp"
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/lemi025_stream_parser.hpp"
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"

#include <Eigen/LU>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <unistd.h>

namespace magnetometer_insitu_calibration {

namespace {

// ---------------------------------------------------------------------------------------------
// Text formats, block by block

bool is_blank(const std::string& line) { return line.find_first_not_of(" \t") == std::string::npos; }

bool is_csv_comment(const std::string& line) {
  const std::size_t first = line.find_first_not_of(" \t");
  return first != std::string::npos && line[first] == '#';
}

/// Same rule as the CSV reader: ';' or tab when they are the most frequent, else ','.
char csv_delimiter(const std::string& line) {
  const auto commas = std::count(line.begin(), line.end(), ',');
  const auto semicolons = std::count(line.begin(), line.end(), ';');
  const auto tabs = std::count(line.begin(), line.end(), '\t');
  if (semicolons > commas && semicolons >= tabs) return ';';
  if (tabs > commas && tabs > semicolons) return '\t';
  return ',';
}

/// The line number of an InputError raised for `path` ("path:N"), if any.
std::optional<std::size_t> error_line(const InputError& error, const std::string& path) {
  const std::string& where = error.where();
  if (where.size() <= path.size() + 1 || where.compare(0, path.size(), path) != 0 || where[path.size()] != ':') {
    return std::nullopt;
  }
  const std::string digits = where.substr(path.size() + 1);
  if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos) return std::nullopt;
  return static_cast<std::size_t>(std::stoull(digits));
}

/// A private temporary directory, removed with its one file.
class TempFile {
 public:
  TempFile() {
    const char* base = std::getenv("TMPDIR");
    std::string pattern = std::string(base != nullptr && *base != '\0' ? base : "/tmp") + "/mic_archive_XXXXXX";
    std::vector<char> buffer(pattern.begin(), pattern.end());
    buffer.push_back('\0');
    if (mkdtemp(buffer.data()) == nullptr) throw std::runtime_error("cannot create a temporary directory in " + pattern);
    dir_ = buffer.data();
    path_ = dir_ + "/block";
  }
  ~TempFile() {
    std::remove(path_.c_str());
    rmdir(dir_.c_str());
  }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string dir_, path_;
};

struct Sample {
  double time_s;
  std::array<double, 3> values;
  std::size_t line;  // 1-based line in the original file
};

/// Reads a damaged IAGA-2002 or CSV file: header records + blocks of data lines through the
/// strict reader.
class BlockReader {
 public:
  BlockReader(const std::string& path, bool iaga, const ArchiveReadOptions& options)
      : path_(path), iaga_(iaga), options_(options) {
    TextLineReader reader(path);
    std::string line;
    while (reader.next(line)) lines_.push_back(line);
  }

  ArchiveRecord read() {
    ArchiveRecord out;
    out.format = iaga_ ? RecordFormat::kIaga2002 : RecordFormat::kCsv;
    const std::size_t data_start = iaga_ ? iaga_prefix() : csv_prefix(out);
    std::vector<Sample> samples;
    std::size_t pos = data_start, block = std::max<std::size_t>(1, options_.first_block_lines);
    const std::size_t n = lines_.size();
    while (pos < n) {
      const std::size_t end = std::min(n, pos + block);
      try {
        append(read_block(pos, end), pos, end, samples);
        pos = end;
        block = std::min(block * 2, std::max<std::size_t>(1, options_.max_block_lines));
      } catch (const InputError& error) {
        const std::optional<std::size_t> temp_line = error_line(error, temp_.path());
        if (!temp_line) {  // e.g. "no data lines": the block holds only blank or comment lines
          if (data_lines(pos, end) > 0) throw;
          pos = end;
          continue;
        }
        if (*temp_line <= prefix_.size()) throw;  // cannot happen: the header read cleanly before
        const std::size_t bad = pos + (*temp_line - prefix_.size() - 1);
        if (bad >= end) throw;
        if (data_lines(pos, bad) > 0) append(read_block(pos, bad), pos, bad, samples);
        bool alone_ok = false;
        try {
          alone_ok = bad > pos && read_block(bad, bad + 1).size() == 1;
        } catch (const InputError&) {
          alone_ok = false;
        }
        if (alone_ok) {
          pos = bad;  // a good line out of time order: kept for the ordering step below
        } else {
          out.problems.push_back(path_ + ":" + std::to_string(bad + 1) + ": " + error.problem() + " (line skipped)");
          ++out.skipped;
          pos = bad + 1;
        }
        block = std::max<std::size_t>(1, options_.first_block_lines);
      }
      if (options_.progress) options_.progress(static_cast<double>(pos) / static_cast<double>(n));
    }
    keep_increasing(samples, out);
    if (samples.empty()) throw InputError(path_, "no good data line");

    VectorRecord& r = out.record;
    r = first_block_;
    r.source = path_;
    if (!iaga_) {  // the '#' lines of the whole file, as the strict reader collects them
      std::string comments;
      bool any = false;
      for (const std::string& line : lines_) {
        if (!is_csv_comment(line)) continue;
        if (any) comments += '\n';
        comments += trim_blanks(line.substr(line.find('#') + 1));
        any = true;
      }
      if (any) r.header["comments"] = comments;
    }
    r.time_s.resize(samples.size());
    r.values_nT.resize(static_cast<Eigen::Index>(samples.size()), 3);
    for (std::size_t i = 0; i < samples.size(); ++i) {
      r.time_s[i] = samples[i].time_s;
      for (int c = 0; c < 3; ++c) r.values_nT(static_cast<Eigen::Index>(i), c) = samples[i].values[c];
    }
    return out;
  }

 private:
  // IAGA-2002: every line up to the column header "DATE TIME DOY ..." is repeated in each block.
  std::size_t iaga_prefix() {
    for (std::size_t i = 0; i < lines_.size(); ++i) {
      if (lines_[i].compare(0, 4, "DATE") == 0) {
        prefix_.assign(lines_.begin(), lines_.begin() + static_cast<std::ptrdiff_t>(i) + 1);
        return i + 1;
      }
    }
    read_iaga2002(path_);  // throws its own message: no column header
    throw InputError(path_, "no column header 'DATE TIME DOY ...'");
  }

  // CSV: comments and blank lines before the first content line, then the header line (or, in
  // a file without one, "time,X,Y,Z" with the file's delimiter, which the reader takes as the
  // default names). A damaged first data line is skipped like any other.
  std::size_t csv_prefix(ArchiveRecord& out) {
    std::size_t c = 0;
    for (;;) {
      while (c < lines_.size() && (is_blank(lines_[c]) || is_csv_comment(lines_[c]))) ++c;
      if (c >= lines_.size()) throw InputError(path_, "no good data line");
      prefix_.clear();  // comments and blank lines before line c (not the damaged lines skipped)
      for (std::size_t i = 0; i < c; ++i) {
        if (is_blank(lines_[i]) || is_csv_comment(lines_[i])) prefix_.push_back(lines_[i]);
      }
      try {
        if (read_block(c, c + 1).size() == 1) {  // a data line: synthetic header
          const char d = csv_delimiter(lines_[c]);
          prefix_.push_back(std::string("time") + d + "X" + d + "Y" + d + "Z");
          return c;
        }
      } catch (const InputError& error) {
        const std::optional<std::size_t> line = error_line(error, temp_.path());
        if (!line) {  // "no data lines": line c is the header
          prefix_.push_back(lines_[c]);
          return c + 1;
        }
        out.problems.push_back(path_ + ":" + std::to_string(c + 1) + ": " + error.problem() + " (line skipped)");
        ++out.skipped;
        ++c;
      }
    }
  }

  std::size_t data_lines(std::size_t first, std::size_t last) const {
    std::size_t count = 0;
    for (std::size_t i = first; i < last; ++i) count += !is_blank(lines_[i]) && (iaga_ || !is_csv_comment(lines_[i]));
    return count;
  }

  VectorRecord read_block(std::size_t first, std::size_t last) {
    {
      std::ofstream file(temp_.path(), std::ios::trunc);
      for (const std::string& line : prefix_) file << line << '\n';
      for (std::size_t i = first; i < last; ++i) file << lines_[i] << '\n';
      if (!file) throw std::runtime_error("cannot write the temporary file " + temp_.path());
    }
    return iaga_ ? read_iaga2002(temp_.path()) : read_csv_record(temp_.path());
  }

  void append(const VectorRecord& block, std::size_t first, std::size_t last, std::vector<Sample>& samples) {
    if (!have_first_) {
      first_block_ = block;
      first_block_.time_s.clear();
      first_block_.values_nT.resize(0, 3);
      have_first_ = true;
    }
    std::size_t k = 0;
    for (std::size_t i = first; i < last; ++i) {
      if (is_blank(lines_[i]) || (!iaga_ && is_csv_comment(lines_[i]))) continue;
      if (k >= block.size()) break;
      const auto row = static_cast<Eigen::Index>(k);
      samples.push_back({block.time_s[k], {block.values_nT(row, 0), block.values_nT(row, 1), block.values_nT(row, 2)}, i + 1});
      ++k;
    }
    if (k != block.size()) throw std::logic_error(path_ + ": lines and samples of a block do not match");
  }

  // Keeps the longest strictly increasing subsequence of times, earliest lines on ties.
  void keep_increasing(std::vector<Sample>& samples, ArchiveRecord& out) const {
    const std::size_t n = samples.size();
    bool sorted = true;
    for (std::size_t i = 1; i < n && sorted; ++i) sorted = samples[i].time_s > samples[i - 1].time_s;
    if (sorted) return;
    // Length of the longest increasing run starting at i, by patience sorting from the end.
    std::vector<std::size_t> from(n);
    std::vector<double> tails;  // tails[k]: largest start time of a decreasing-from-the-end run of length k+1
    for (std::size_t j = n; j-- > 0;) {
      const double key = -samples[j].time_s;
      const auto it = std::lower_bound(tails.begin(), tails.end(), key);
      from[j] = static_cast<std::size_t>(it - tails.begin()) + 1;
      if (it == tails.end()) tails.push_back(key);
      else *it = key;
    }
    std::size_t need = tails.size();
    double last = -std::numeric_limits<double>::infinity();
    std::vector<Sample> kept;
    kept.reserve(need);
    double previous_kept = last;
    std::size_t previous_line = 0;
    for (const Sample& s : samples) {
      if (need > 0 && from[&s - samples.data()] == need && s.time_s > last) {
        kept.push_back(s);
        last = s.time_s;
        previous_kept = s.time_s;
        previous_line = s.line;
        --need;
        continue;
      }
      std::ostringstream message;
      message.precision(15);
      message << path_ << ":" << s.line << ": time " << s.time_s << " s out of order";
      if (previous_line > 0) message << " (line " << previous_line << " has " << previous_kept << " s)";
      message << " (line skipped)";
      out.problems.push_back(message.str());
      ++out.skipped;
    }
    samples = std::move(kept);
  }

  std::string path_;
  bool iaga_;
  ArchiveReadOptions options_;
  std::vector<std::string> lines_;
  std::vector<std::string> prefix_;
  TempFile temp_;
  VectorRecord first_block_;
  bool have_first_ = false;
};

// ---------------------------------------------------------------------------------------------
// LEMI temperatures

RecordTemperatures temperatures_of(const std::vector<Lemi025Packet>& packets, const LemiReadOptions& options) {
  RecordTemperatures t;
  const double extra_shift_s = options.time_shift_s - kLemi025TimeShift_s;
  for (const Lemi025Packet& p : packets) {
    const double time_s = p.sample_time_s(0) + extra_shift_s;
    if (!std::isfinite(time_s) || (!t.time_s.empty() && !(time_s > t.time_s.back()))) continue;
    t.time_s.push_back(time_s);
    t.sensor_C.push_back(p.sensor_temperature_C);
    t.electronics_C.push_back(p.electronics_temperature_C);
  }
  return t;
}

std::vector<Lemi025Packet> lemi_packets(const std::string& path, RecordFormat format, const LemiReadOptions& options) {
  std::vector<Lemi025Packet> packets;
  if (format == RecordFormat::kLemiBin) {
    for (const LemiBinRecord& r : read_lemi_bin_file(path, options, nullptr).records) packets.push_back(r.packet);
  } else if (format == RecordFormat::kLemiCompactFlash) {
    for (const LemiFlashBlock& b : read_lemi_flash_blocks(path, nullptr)) {
      for (int s = 0; s < 3; ++s) packets.push_back(lemi_flash_block_second(b, s));
    }
  } else {
    std::ifstream in(path, std::ios::binary);
    Lemi025ParserOptions parser_options;
    parser_options.checksum = options.checksum;
    parser_options.plausibility = options.plausibility;
    parser_options.max_warnings = 0;
    Lemi025StreamParser parser(parser_options);
    std::vector<std::uint8_t> chunk(1 << 16);
    while (in) {
      in.read(reinterpret_cast<char*>(chunk.data()), static_cast<std::streamsize>(chunk.size()));
      const auto got = static_cast<std::size_t>(in.gcount());
      if (got == 0) break;
      for (Lemi025Packet& p : parser.feed(chunk.data(), got)) packets.push_back(std::move(p));
    }
  }
  return packets;
}

double json_number(const nlohmann::json& value, const std::string& path, const std::string& what,
                   bool null_is_nan = false) {
  if (null_is_nan && value.is_null()) return std::numeric_limits<double>::quiet_NaN();
  if (!value.is_number()) throw InputError(path, what + " is not a number (null: the estimate was not finite)");
  return value.get<double>();
}

Eigen::Matrix3d json_matrix(const nlohmann::json& window, const char* key, const std::string& path,
                            const std::string& where, bool null_is_nan = false) {
  if (!window.contains(key) || !window[key].is_array() || window[key].size() != 3) {
    throw InputError(path, where + ": no 3x3 \"" + key + "\"");
  }
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r) {
    const nlohmann::json& row = window[key][static_cast<std::size_t>(r)];
    if (!row.is_array() || row.size() != 3) throw InputError(path, where + ": \"" + key + "\" is not 3x3");
    for (int c = 0; c < 3; ++c) {
      m(r, c) = json_number(row[static_cast<std::size_t>(c)], path,
                            where + ": " + key + "[" + std::to_string(r) + "][" + std::to_string(c) + "]",
                            null_is_nan);
    }
  }
  return m;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

ArchiveRecord read_archive_record(const std::string& path, const ArchiveReadOptions& options) {
  const RecordFormat format = detect_record_format(path);
  if (format == RecordFormat::kIaga2002 || format == RecordFormat::kCsv) {
    try {
      ArchiveRecord out;
      out.format = format;
      out.record = read_record(path, options.lemi, &out.problems);  // a dropped last line's warning
      return out;
    } catch (const InputError& error) {
      // Only a damaged data line is worth a second, tolerant pass; anything else (missing file,
      // no column header) is reported as it is.
      if (!error_line(error, path)) throw;
    }
    BlockReader reader(path, format == RecordFormat::kIaga2002, options);
    return reader.read();
  }
  ArchiveRecord out;
  out.format = format;
  if (format == RecordFormat::kCdf) {  // temperatures: MagPy t1 (sensor), t2 (electronics); ImagCDF Temperature1, 2
    out.record = read_record(path);
    const std::vector<AuxiliaryChannel>& aux = out.record.auxiliary;
    if (!aux.empty()) {
      out.temperatures.time_s = out.record.time_s;
      out.temperatures.sensor_C = aux[0].values;
      out.temperatures.electronics_C =
          aux.size() > 1 ? aux[1].values : std::vector<double>(aux[0].values.size(), std::numeric_limits<double>::quiet_NaN());
    }
    return out;
  }
  out.record = read_record(path, options.lemi, &out.problems);
  for (const std::string& w : out.problems) out.skipped += w.find("erased blocks skipped") == std::string::npos;
  out.temperatures = temperatures_of(lemi_packets(path, format, options.lemi), options.lemi);
  return out;
}

VectorRecord correct_record(const VectorRecord& test, const Eigen::Matrix3d& n,
                            const std::array<std::string, 3>& components, double max_condition) {
  if (!n.allFinite()) throw InputError("calibration", "matrix n is not finite");
  // Condition number of n: ratio of its extreme singular values (eigenvalues of n^T n).
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(n.transpose() * n);
  const double condition = std::sqrt(eigen.eigenvalues()(2) / eigen.eigenvalues()(0));
  if (!(condition <= max_condition)) {
    std::ostringstream text;
    text << "matrix n has condition number " << condition << " (> " << max_condition << "): not invertible enough";
    throw InputError("calibration", text.str());
  }
  VectorRecord out = test;
  out.components = components;
  out.values_nT = test.values_nT * n.inverse();  // rows: r = t n^-1; a NaN row stays NaN
  return out;
}

nlohmann::json read_json_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "cannot open");
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path, std::string("not valid JSON: ") + e.what());
  }
}

ReportWindow select_report_window(const nlohmann::json& report, const std::string& which, const std::string& path) {
  if (!report.is_object() || !report.contains("windows") || !report["windows"].is_array() || report["windows"].empty()) {
    throw InputError(path, "no \"windows\" array: not a calibrate_records --json report?");
  }
  const nlohmann::json& windows = report["windows"];
  std::optional<std::size_t> index;
  if (!which.empty() && which.find_first_not_of("0123456789") == std::string::npos) {
    const std::size_t k = std::stoul(which);
    if (k < 1 || k > windows.size()) {
      throw InputError(path, "window " + which + " does not exist (the report has " + std::to_string(windows.size()) +
                                 " windows)");
    }
    index = k - 1;
  } else {
    const std::string wanted = which.empty() ? "whole record" : which;
    for (std::size_t i = 0; i < windows.size() && !index; ++i) {
      if (windows[i].value("label", "") == wanted) index = i;
    }
    if (!index && which.empty()) {
      for (std::size_t i = windows.size(); i-- > 0 && !index;) {
        if (windows[i].value("quality", "") == "ok") index = i;
      }
      if (!index) throw InputError(path, "no \"whole record\" window and no window of quality ok");
    }
    if (!index) throw InputError(path, "no window labelled '" + which + "'");
  }
  ReportWindow w;
  w.index = *index;
  w.json = windows[*index];
  w.label = w.json.value("label", "window " + std::to_string(*index + 1));
  w.start = w.json.value("window_start", "");
  w.end = w.json.value("window_end", "");
  w.quality = w.json.value("quality", "");
  const std::string where = "window '" + w.label + "'";
  w.n = json_matrix(w.json, "matrix", path, where);
  if (w.json.contains("matrix_stderr")) w.n_stderr = json_matrix(w.json, "matrix_stderr", path, where, true);
  return w;
}

}  // namespace magnetometer_insitu_calibration
