// Writes the seed corpus of the fuzz targets, fuzz/corpus/<target>/, from real samples: the head
// of the WIC IAGA-2002 file shipped in data/ (header and first seconds of LEMI-036 data), CSV
// lines made from the same data, LEMI-025 packets, LemiBin files and compact-flash blocks made
// with the library's own encoders from those readings; and (make_seeds_cdf_yaml.cpp) small CDF
// files made from the first seconds of the WIC LEMI-036 MagPy CDF in test/data/cdf, and a
// calibration YAML written by calibration_to_yaml. The outputs are small and committed; re-run
// after a format change:
//   build_fuzz/make_seeds <package root> <package root>/fuzz/corpus
#include "make_seeds.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/lemi025_packet.hpp"
#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include <zlib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <iterator>
#include <sstream>
#include <string>
#include <sys/stat.h>
#include <vector>

using namespace magnetometer_insitu_calibration;
using namespace make_seeds;

namespace {

void make_dir(const std::string& path) {
  if (::mkdir(path.c_str(), 0755) != 0 && errno != EEXIST) {
    std::perror(path.c_str());
    std::exit(1);
  }
}

}  // namespace

namespace make_seeds {

std::string g_out;

void write(const std::string& target, const std::string& name, const Bytes& bytes) {
  make_dir(g_out + "/" + target);
  const std::string path = g_out + "/" + target + "/" + name;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!out) {
    std::cerr << "cannot write " << path << "\n";
    std::exit(1);
  }
}

void write(const std::string& target, const std::string& name, const std::string& text) {
  write(target, name, Bytes(text.begin(), text.end()));
}

Bytes read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    std::cerr << "cannot read " << path << "\n";
    std::exit(1);
  }
  return Bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

}  // namespace make_seeds

namespace {

Bytes gzip(const std::string& text) {
  Bytes out(compressBound(static_cast<uLong>(text.size())) + 64);
  z_stream z{};
  deflateInit2(&z, 9, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY);
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(text.data()));
  z.avail_in = static_cast<uInt>(text.size());
  z.next_out = out.data();
  z.avail_out = static_cast<uInt>(out.size());
  deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  return out;
}

void append(Bytes& to, const Bytes& from) { to.insert(to.end(), from.begin(), from.end()); }

/// Pads with 0x00 so that size % 3 == mod (the LEMI file targets take the checksum mode from it).
Bytes pad_to_mod3(Bytes b, std::size_t mod) {
  while (b.size() % 3 != mod) b.push_back(0);
  return b;
}

// ---- The WIC sample -------------------------------------------------------------------------

struct Wic {
  std::vector<std::string> header_lines;  // up to and including the DATE column header
  std::vector<std::string> data_lines;
  std::vector<double> time_s;
  std::vector<std::array<double, 3>> hez;
};

Wic read_wic(const std::string& path, std::size_t data_lines) {
  Wic w;
  TextLineReader reader(path);
  std::string line;
  bool in_data = false;
  while (reader.next(line) && w.data_lines.size() < data_lines) {
    if (!in_data) {
      w.header_lines.push_back(line);
      in_data = line.compare(0, 4, "DATE") == 0;
      continue;
    }
    w.data_lines.push_back(line);
    std::istringstream words(line);
    std::string date, time, doy;
    std::array<double, 3> v{};
    double f = 0;
    words >> date >> time >> doy >> v[0] >> v[1] >> v[2] >> f;
    w.time_s.push_back(parse_iso8601(date + " " + time));
    w.hez.push_back(v);
  }
  return w;
}

std::string crlf_join(const std::vector<std::string>& lines) {
  std::string text;
  for (const auto& l : lines) text += l + "\r\n";
  return text;
}

// A LEMI-025 packet for second `s` of the WIC sample: the readings are the WIC 1 Hz values of
// seconds s .. s+9 (as variations, nT), bias (20000, 2500, 44000) nT.
Lemi025Packet wic_packet(const Wic& w, std::size_t s, LemiModel model = LemiModel::kLemi025) {
  Lemi025Packet p;
  p.model = model;
  p.station = 7;
  p.gps_time_s = w.time_s[s];
  p.sensor_temperature_C = 12.34;
  p.electronics_temperature_C = 21.5;
  p.dac_counts = {{1200, -340, 2800}};
  p.bias_nT = Eigen::Vector3d(20000.0, 2500.0, 44000.0);
  for (int k = 0; k < kLemi025ReadingsPerPacket; ++k)
    for (int c = 0; c < 3; ++c) p.variation_nT(k, c) = w.hez[s + k][c];
  p.mode = 3;
  p.flash_free_percent = 87;
  p.supply_V = 12.3;
  p.gps_status = 'A';
  p.checksum = 0x5a;
  return p;
}

Bytes packet_bytes(const Lemi025Packet& p, ChecksumMode mode) {
  const auto a = encode_lemi025_packet(p, mode);
  return Bytes(a.begin(), a.end());
}

LemiFlashBlock wic_block(const Wic& w, std::size_t s) {
  LemiFlashBlock b;
  b.station = 7;
  b.time_s = w.time_s[s];
  b.latitude_deg = 47.930;   // Conrad Observatory
  b.longitude_deg = 15.865;
  b.gps_status = 'A';
  b.supply_V = 12.3;
  b.bias_nT = Eigen::Vector3d(20000.0, 2500.0, 44000.0);
  b.service = 0x01;
  for (int j = 0; j < kLemiFlashReadingsPerBlock; ++j) {
    for (int c = 0; c < 3; ++c) b.variation_nT(j, c) = w.hez[s + j / 10][c] + 0.01 * (j % 10);
    b.sensor_temperature_C[j] = 12.34;
    b.electronics_temperature_C[j] = 21.5;
  }
  return b;
}

Bytes block_bytes(const LemiFlashBlock& b) {
  const auto a = encode_lemi_flash_block(b);
  return Bytes(a.begin(), a.end());
}

std::string lemi_bin_file(const std::vector<Lemi025Packet>& packets, ChecksumMode mode) {
  std::vector<LemiBinRecord> records;
  for (const auto& p : packets) {
    LemiBinRecord r;
    r.packet = p;
    r.pc_time_s = p.gps_time_s + 0.412;
    records.push_back(r);
  }
  const std::string path = g_out + "/.lemibin.tmp";
  write_lemi_bin(path, records, "LEMI036_1_0002", mode);
  const Bytes b = read_bytes(path);
  std::remove(path.c_str());
  return std::string(b.begin(), b.end());
}

// ---- The seeds of each target --------------------------------------------------------------

/// iaga2002: the WIC head (CRLF line ends; and gzipped), with LF line ends, a missing value and
/// a blank line, and the test files. Returns the head's text.
std::string write_iaga2002_seeds(const std::string& root, const Wic& w) {
  std::vector<std::string> head = w.header_lines;
  for (std::size_t i = 0; i < 12; ++i) head.push_back(w.data_lines[i]);
  const std::string iaga = crlf_join(head);
  write("iaga2002", "wic_head.sec", iaga);
  write("iaga2002", "wic_head.sec.gz", gzip(iaga));
  std::vector<std::string> lf = head;  // LF line ends, a missing (99999) and a blank line
  lf[w.header_lines.size() + 3].replace(30, 10, "  99999.00");
  lf.insert(lf.begin() + static_cast<std::ptrdiff_t>(w.header_lines.size() + 5), "");
  std::string text;
  for (const auto& l : lf) text += l + "\n";
  write("iaga2002", "wic_lf_missing.sec", text);
  for (const char* name : {"iaga_small.sec", "iaga_short_line.sec", "iaga_bad_date.sec",
                           "iaga_duplicate.sec"})
    write("iaga2002", name, read_bytes(root + "/test/data/formats/" + name));
  return iaga;
}

/// csv_record: UNIX times with comments (and gzipped), ISO times with ';', CRLF and a NaN, tabs
/// with a quoted header and a 99999, no header with a BOM, and the test files. Returns the first.
std::string write_csv_seeds(const std::string& root, const Wic& w) {
  std::ostringstream unix_csv, iso_csv, tab_csv;
  unix_csv.precision(15);
  unix_csv << "# WIC LEMI036, 2025-05-14\n# first seconds\ntime,H,E,Z\n";
  iso_csv << "time;X;Y;Z\n";
  tab_csv << "\"time\"\t\"H\"\t\"E\"\t\"Z\"\n";
  for (std::size_t i = 0; i < 12; ++i) {
    unix_csv << w.time_s[i] << "," << w.hez[i][0] << "," << w.hez[i][1] << "," << w.hez[i][2] << "\n";
    iso_csv << format_iso8601(w.time_s[i], 3) << ";" << w.hez[i][0] << ";" << (i == 4 ? "nan" : "")
            << (i == 4 ? "" : std::to_string(w.hez[i][1])) << ";" << w.hez[i][2] << "\r\n";
    tab_csv << format_iso8601(w.time_s[i], 0) << "\t" << w.hez[i][0] << "\t" << w.hez[i][1] << "\t"
            << (i == 7 ? "99999" : std::to_string(w.hez[i][2])) << "\n";
  }
  write("csv_record", "wic_unix.csv", unix_csv.str());
  write("csv_record", "wic_unix.csv.gz", gzip(unix_csv.str()));
  write("csv_record", "wic_iso_semicolon.csv", iso_csv.str());
  write("csv_record", "wic_tab_quoted.tsv", tab_csv.str());
  write("csv_record", "no_header_bom.csv",
        "\xEF\xBB\xBF" "1747180800.5,341.93,545.24,376.19\n1747180801.5,+341.96,5.4524e2,NaN\n");
  for (const char* name : {"csv_iso_semicolon.csv", "csv_unix.csv"})
    write("csv_record", name, read_bytes(root + "/test/data/formats/" + name));
  return unix_csv.str();
}

/// lemi025_packet: a LEMI-025 packet without checksum, LEMI-036 ones with sum8 and xor8, and one
/// with a time byte not BCD.
void write_packet_seeds(const Wic& w) {
  write("lemi025_packet", "l025_none.bin", packet_bytes(wic_packet(w, 0), ChecksumMode::kNone));
  Lemi025Packet p = wic_packet(w, 1, LemiModel::kLemi036);
  p.gps_status = 'P';
  write("lemi025_packet", "l036_sum8.bin", packet_bytes(p, ChecksumMode::kSum8));
  p.gps_status = 'O';
  p.mode = 1;
  write("lemi025_packet", "l036_xor8.bin", packet_bytes(p, ChecksumMode::kXor8));
  Bytes bad = packet_bytes(p, ChecksumMode::kNone);
  bad[9] = 0x7a;  // minute byte not BCD
  write("lemi025_packet", "bad_bcd_time.bin", bad);
}

/// lemi025_stream_parser (byte 0 options, byte 1 chunk seed, then the stream): clean, noisy, jumps.
void write_stream_parser_seeds(const std::vector<Lemi025Packet>& packets) {
  Bytes clean = {0x00, 0x11};
  for (const auto& p : packets) append(clean, packet_bytes(p, ChecksumMode::kNone));
  write("lemi025_stream_parser", "clean_none.bin", clean);

  Bytes noisy = {0x01, 0x37};  // sum8: garbage, a packet short of 5 bytes, a bad checksum
  append(noisy, Bytes{'x', 'L', '0', '2', 0x00, 'L', '0'});
  for (std::size_t i = 0; i < packets.size(); ++i) {
    Bytes b = packet_bytes(packets[i], ChecksumMode::kSum8);
    if (i == 2) b.erase(b.begin() + 60, b.begin() + 65);
    if (i == 4) b[70] ^= 0x10;
    append(noisy, b);
  }
  noisy.resize(noisy.size() - 40);  // cut in the last packet
  write("lemi025_stream_parser", "noisy_sum8.bin", noisy);

  Bytes jumps = {0x0e, 0xa5};  // xor8, no status check, 2 warnings kept; a time jump
  for (std::size_t i : {0, 1, 5, 6, 3}) append(jumps, packet_bytes(packets[i], ChecksumMode::kXor8));
  write("lemi025_stream_parser", "jumps_xor8.bin", jumps);
}

/// lemi025_stream (raw capture file; checksum from size % 3): clean, and damaged with garbage.
void write_stream_seeds(const std::vector<Lemi025Packet>& packets) {
  Bytes clean;
  for (const auto& p : packets) append(clean, packet_bytes(p, ChecksumMode::kNone));
  write("lemi025_stream", "capture_none.bin", pad_to_mod3(clean, 0));
  Bytes noisy = {0xff, 0x00, 'L', '0', '3'};
  for (std::size_t i = 0; i < 5; ++i) {
    Bytes b = packet_bytes(packets[i], ChecksumMode::kSum8);
    if (i == 1) b.resize(100);  // serial line dropped the rest
    append(noisy, b);
  }
  write("lemi025_stream", "capture_sum8_damaged.bin", pad_to_mod3(noisy, 1));
}

/// lemi_bin (checksum from size % 3): 4 records, 4 with a damaged reading, 3 without header.
void write_lemi_bin_seeds(const std::vector<Lemi025Packet>& packets) {
  const std::string none = lemi_bin_file({packets.begin(), packets.begin() + 4}, ChecksumMode::kNone);
  write("lemi_bin", "wic_none.bin", pad_to_mod3(Bytes(none.begin(), none.end()), 0));
  const std::string sum8 = lemi_bin_file({packets.begin(), packets.begin() + 4}, ChecksumMode::kSum8);
  Bytes damaged(sum8.begin(), sum8.end());
  damaged[sum8.find('\n') + 1 + 169 + 40] ^= 0xff;  // second record's reading damaged
  write("lemi_bin", "wic_sum8_damaged.bin", pad_to_mod3(damaged, 1));
  const std::string xor8 = lemi_bin_file({packets.begin(), packets.begin() + 3}, ChecksumMode::kXor8);
  const Bytes headerless(xor8.begin() + static_cast<std::ptrdiff_t>(xor8.find('\n') + 1), xor8.end());
  write("lemi_bin", "headerless_xor8.bin", pad_to_mod3(headerless, 2));
}

/// lemi_compact_flash: 3 blocks (one erased); misaligned, a block without a position fix, a
/// truncated tail.
void write_compact_flash_seeds(const Wic& w) {
  Bytes card;
  append(card, block_bytes(wic_block(w, 0)));
  append(card, Bytes(kLemiFlashBlockSize, 0xff));  // erased
  append(card, block_bytes(wic_block(w, 3)));
  write("lemi_compact_flash", "card_3_blocks.bin", card);
  Bytes shifted(37, 0x00);  // misaligned, a block with no position fix, a truncated tail
  LemiFlashBlock nofix = wic_block(w, 6);
  nofix.latitude_deg = std::nan("");
  nofix.longitude_deg = std::nan("");
  nofix.gps_status = 'S';
  append(shifted, block_bytes(nofix));
  append(shifted, block_bytes(wic_block(w, 9)));
  const Bytes tail = block_bytes(wic_block(w, 12));
  shifted.insert(shifted.end(), tail.begin(), tail.begin() + 100);
  write("lemi_compact_flash", "card_misaligned.bin", shifted);
}

/// record_file: one of each format (the IAGA-2002 and CSV texts of their own targets).
void write_record_file_seeds(const Wic& w, const std::vector<Lemi025Packet>& packets, const std::string& iaga,
                             const std::string& unix_csv) {
  write("record_file", "iaga.sec", iaga);
  write("record_file", "unix.csv", unix_csv);
  const std::string bin = lemi_bin_file({packets.begin(), packets.begin() + 2}, ChecksumMode::kNone);
  write("record_file", "lemibin.bin", bin);
  Bytes stream;
  for (std::size_t i = 0; i < 2; ++i) append(stream, packet_bytes(packets[i], ChecksumMode::kNone));
  write("record_file", "stream.bin", stream);
  write("record_file", "flash.bin", block_bytes(wic_block(w, 0)));
  write("record_file", "iaga.sec.gz", gzip(iaga));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: make_seeds <package root> <corpus dir>\n";
    return 2;
  }
  const std::string root = argv[1];
  g_out = argv[2];
  make_dir(g_out);
  try {
    const Wic w = read_wic(root + "/data/wic20250514_lemi036.sec.gz", 40);
    const std::string iaga = write_iaga2002_seeds(root, w);
    const std::string unix_csv = write_csv_seeds(root, w);
    write_packet_seeds(w);
    // Packets of consecutive seconds for the streams and files.
    std::vector<Lemi025Packet> packets;
    for (std::size_t s = 0; s < 8; ++s) packets.push_back(wic_packet(w, s));
    write_stream_parser_seeds(packets);
    write_stream_seeds(packets);
    write_lemi_bin_seeds(packets);
    write_compact_flash_seeds(w);
    write_record_file_seeds(w, packets, iaga, unix_csv);
    write_cdf_seeds(root);
#ifdef MIC_FUZZ_WITH_YAML
    write_calibration_yaml_seeds(root);
#endif
  } catch (const std::exception& e) {
    std::cerr << "make_seeds: " << e.what() << "\n";
    return 1;
  }
  std::cout << "make_seeds: corpus written to " << g_out << "\n";
  return 0;
}
