// CDF 3 encoder; see cdf_writer.hpp. Layout: magic numbers, CDR, GDR, attributes (each ADR
// followed by its AEDRs), then per variable its zVDR, VXR and VVR. Offsets are patched in once
// the record they point to is placed.
#include "magnetometer_insitu_calibration/formats/cdf_writer.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <map>

namespace magnetometer_insitu_calibration {

namespace {

constexpr std::int32_t kCdr = 1, kGdr = 2, kAdr = 4, kAgredr = 5, kVxr = 6, kVvr = 7, kZvdr = 8, kAzedr = 9,
                       kCcr = 10, kCpr = 11, kCvvr = 13;

/// gzip stream of `bytes` (level 6).
std::vector<std::uint8_t> gzip(const std::vector<std::uint8_t>& bytes) {
  z_stream z{};
  if (deflateInit2(&z, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
    throw InputError("CDF writer", "zlib initialisation failed");
  }
  std::vector<std::uint8_t> out(deflateBound(&z, static_cast<uLong>(bytes.size())) + 32);
  z.next_in = const_cast<Bytef*>(bytes.data());
  z.avail_in = static_cast<uInt>(bytes.size());
  z.next_out = out.data();
  z.avail_out = static_cast<uInt>(out.size());
  const int rc = deflate(&z, Z_FINISH);
  out.resize(out.size() - z.avail_out);
  deflateEnd(&z);
  if (rc != Z_STREAM_END) throw InputError("CDF writer", "GZIP compression failed");
  return out;
}
constexpr std::size_t kNameLength = 256;

class Buffer {
 public:
  std::vector<std::uint8_t> bytes;
  bool v3 = true;  ///< offsets and record sizes: 8 bytes (CDF 3) or 4 (CDF 2); names 256 or 64
  std::size_t offset_size() const { return v3 ? 8 : 4; }
  std::size_t size() const { return bytes.size(); }
  void i32(std::int32_t v) { u(static_cast<std::uint32_t>(v), 4); }
  /// An offset or a record size.
  void i64(std::int64_t v) { u(static_cast<std::uint64_t>(v), static_cast<int>(offset_size())); }
  void name(const std::string& text) {
    const std::size_t length = v3 ? kNameLength : 64;
    if (text.size() > length) throw InputError("CDF writer", "name '" + text + "' is too long for this CDF version");
    bytes.insert(bytes.end(), text.begin(), text.end());
    bytes.insert(bytes.end(), length - text.size(), 0);
  }
  /// Starts a record: size placeholder and type; returns its offset.
  std::size_t begin(std::int32_t type) {
    const std::size_t at = size();
    i64(0);
    i32(type);
    return at;
  }
  void end(std::size_t record) { patch64(record, static_cast<std::int64_t>(size() - record)); }
  /// Sets the offset or size written at `at`.
  void patch64(std::size_t at, std::int64_t v) {
    const int n = static_cast<int>(offset_size());
    for (int i = 0; i < n; ++i) {
      bytes[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(static_cast<std::uint64_t>(v) >> (8 * (n - 1 - i)));
    }
  }
  /// A value in the data encoding.
  void data(std::uint64_t bits, bool big_endian) {
    for (int i = 0; i < 8; ++i) bytes.push_back(static_cast<std::uint8_t>(bits >> (big_endian ? 56 - 8 * i : 8 * i)));
  }
  void real(double v, bool big_endian) {
    std::uint64_t bits;
    std::memcpy(&bits, &v, 8);
    data(bits, big_endian);
  }

 private:
  void u(std::uint64_t v, int n) {
    for (int i = n - 1; i >= 0; --i) bytes.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
};

/// One AEDR for `entry` as entry number `number` of attribute `attribute`; returns its offset
/// (its next-pointer after the record's size and type).
std::size_t write_entry(Buffer& b, std::int32_t type, std::int32_t attribute, std::int32_t number,
                        const CdfWriteEntry& entry, bool big_endian) {
  const std::size_t at = b.begin(type);
  b.i64(0);  // next AEDR
  b.i32(attribute);
  std::string text = entry.text.empty() ? " " : entry.text;
  if (!entry.times.empty()) {
    b.i32(kCdfTimeTt2000);
    b.i32(number);
    b.i32(static_cast<std::int32_t>(entry.times.size()));
  } else if (!entry.numbers.empty()) {
    b.i32(kCdfDouble);
    b.i32(number);
    b.i32(static_cast<std::int32_t>(entry.numbers.size()));
  } else {
    b.i32(kCdfChar);
    b.i32(number);
    b.i32(static_cast<std::int32_t>(text.size()));
  }
  b.i32(entry.times.empty() && entry.numbers.empty() ? 1 : 0);  // NumStrings
  for (int i = 0; i < 4; ++i) b.i32(0);                           // rfuB..rfuE
  if (!entry.times.empty()) {
    for (std::int64_t t : entry.times) b.data(static_cast<std::uint64_t>(t), big_endian);
  } else if (!entry.numbers.empty()) {
    for (double v : entry.numbers) b.real(v, big_endian);
  } else {
    b.bytes.insert(b.bytes.end(), text.begin(), text.end());
  }
  b.end(at);
  return at;
}

/// A CPR for GZIP level 6; returns its offset.
std::size_t write_gzip_cpr(Buffer& b) {
  const std::size_t at = b.begin(kCpr);
  b.i32(5), b.i32(0), b.i32(1), b.i32(6);  // cType GZIP, rfuA, pCount, level
  b.end(at);
  return at;
}

}  // namespace

std::vector<std::uint8_t> encode_cdf(const CdfWriteContent& content) {
  const bool big = content.big_endian;
  if (content.version != 2 && content.version != 3) throw InputError("CDF writer", "version 2 (2.7) or 3 (3.9) only");
  Buffer b;
  b.v3 = content.version == 3;
  const std::size_t next_at = b.v3 ? 12 : 8;  // a record's next-pointer, after its size and type
  b.bytes = b.v3 ? std::vector<std::uint8_t>{0xCD, 0xF3, 0x00, 0x01, 0x00, 0x00, 0xFF, 0xFF}
                 : std::vector<std::uint8_t>{0xCD, 0xF2, 0x60, 0x02, 0x00, 0x00, 0xFF, 0xFF};
  // CDR: version 3.9.0, row major + single file, encoding NETWORK (1) or IBMPC (6).
  const std::size_t cdr = b.begin(kCdr);
  const std::size_t cdr_gdr = b.size();
  b.i64(0);
  b.i32(b.v3 ? 3 : 2), b.i32(b.v3 ? 9 : 7), b.i32(big ? 1 : 6), b.i32(3), b.i32(0), b.i32(0), b.i32(0), b.i32(-1), b.i32(-1);
  std::string copyright = "Common Data Format (CDF)\nwritten by magnetometer_insitu_calibration\n";
  copyright.resize(256, '\0');
  b.bytes.insert(b.bytes.end(), copyright.begin(), copyright.end());
  b.end(cdr);
  // GDR.
  const std::size_t gdr = b.begin(kGdr);
  b.patch64(cdr_gdr, static_cast<std::int64_t>(gdr));
  b.i64(0);  // rVDR head
  const std::size_t gdr_zvdr = b.size();
  b.i64(0);
  const std::size_t gdr_adr = b.size();
  b.i64(0);
  const std::size_t gdr_eof = b.size();
  b.i64(0);
  // Attributes: the global ones, then the variable ones in order of first use.
  std::vector<std::string> variable_attributes;
  for (const CdfWriteVariable& v : content.variables) {
    if (v.data_type != kCdfDouble && v.data_type != kCdfTimeTt2000 && v.data_type != kCdfEpoch) {
      throw InputError("CDF writer", "variable " + v.name + ": data type " + std::to_string(v.data_type) + " not written");
    }
    for (const auto& [name, entry] : v.attributes) {
      if (std::find(variable_attributes.begin(), variable_attributes.end(), name) == variable_attributes.end()) {
        variable_attributes.push_back(name);
      }
    }
  }
  const auto attribute_count = static_cast<std::int32_t>(content.global.size() + variable_attributes.size());
  b.i32(0);                // NrVars
  b.i32(attribute_count);  // NumAttr
  b.i32(-1);               // rMaxRec
  b.i32(0);                // rNumDims
  b.i32(static_cast<std::int32_t>(content.variables.size()));
  b.i64(0);         // UIR head
  b.i32(0);         // rfuC
  b.i32(b.v3 ? 20170101 : -1);  // leap-second table last updated (rfuD in CDF 2)
  b.i32(-1);        // rfuE
  b.end(gdr);

  std::size_t previous_next = gdr_adr;  // where the next ADR's offset goes
  std::int32_t number = 0;
  auto begin_adr = [&](const std::string& name, std::int32_t scope, std::int32_t gr_entries, std::int32_t z_entries,
                       std::int32_t max_z, std::size_t& gr_head, std::size_t& z_head) {
    const std::size_t adr = b.begin(kAdr);
    b.patch64(previous_next, static_cast<std::int64_t>(adr));
    previous_next = b.size();
    b.i64(0);  // next ADR
    gr_head = b.size();
    b.i64(0);
    b.i32(scope), b.i32(number), b.i32(gr_entries), b.i32(gr_entries - 1), b.i32(0);
    z_head = b.size();
    b.i64(0);
    b.i32(z_entries), b.i32(max_z), b.i32(0);
    b.name(name);
    b.end(adr);
  };
  for (const auto& [name, entries] : content.global) {
    std::size_t gr_head = 0, z_head = 0;
    begin_adr(name, 1, static_cast<std::int32_t>(entries.size()), 0, -1, gr_head, z_head);
    std::size_t link = gr_head;
    for (std::size_t e = 0; e < entries.size(); ++e) {
      const std::size_t aedr = write_entry(b, kAgredr, number, static_cast<std::int32_t>(e), entries[e], big);
      b.patch64(link, static_cast<std::int64_t>(aedr));
      link = aedr + next_at;
    }
    ++number;
  }
  for (const std::string& name : variable_attributes) {
    std::map<std::int32_t, const CdfWriteEntry*> entries;
    for (std::size_t v = 0; v < content.variables.size(); ++v) {
      for (const auto& [attribute, entry] : content.variables[v].attributes) {
        if (attribute == name) entries[static_cast<std::int32_t>(v)] = &entry;
      }
    }
    std::size_t gr_head = 0, z_head = 0;
    begin_adr(name, 2, 0, static_cast<std::int32_t>(entries.size()), entries.rbegin()->first, gr_head, z_head);
    std::size_t link = z_head;
    for (const auto& [variable, entry] : entries) {
      const std::size_t aedr = write_entry(b, kAzedr, number, variable, *entry, big);
      b.patch64(link, static_cast<std::int64_t>(aedr));
      link = aedr + next_at;
    }
    ++number;
  }

  previous_next = gdr_zvdr;
  for (std::size_t v = 0; v < content.variables.size(); ++v) {
    const CdfWriteVariable& var = content.variables[v];
    const bool time = var.data_type == kCdfTimeTt2000;
    const std::size_t records = time ? var.times.size() : var.values.size();
    const std::size_t vdr = b.begin(kZvdr);
    b.patch64(previous_next, static_cast<std::int64_t>(vdr));
    previous_next = b.size();
    b.i64(0);  // next VDR
    b.i32(var.data_type);
    b.i32(static_cast<std::int32_t>(records) - 1);  // MaxRec
    const std::size_t vxr_head = b.size();
    b.i64(0), b.i64(0);  // VXR head, tail
    b.i32(content.gzip_variables ? 5 : 1);    // flags: record variance, compressed
    b.i32(0), b.i32(0), b.i32(0), b.i32(-1);  // SRecords, rfuB, rfuC, rfuF
    b.i32(1);                                 // NumElems
    b.i32(static_cast<std::int32_t>(v));      // Num
    const std::size_t cpr_offset = b.size();
    b.i64(-1);                                // CPR/SPR offset: none until a CPR is written
    b.i32(0);                                 // blocking factor
    b.name(var.name);
    b.i32(0);  // zNumDims
    b.end(vdr);
    if (records == 0) continue;
    const std::size_t vxr = b.begin(kVxr);
    b.patch64(vxr_head, static_cast<std::int64_t>(vxr));
    b.patch64(vxr_head + b.offset_size(), static_cast<std::int64_t>(vxr));
    b.i64(0);        // next VXR
    b.i32(1), b.i32(1);  // Nentries, NusedEntries
    b.i32(0), b.i32(static_cast<std::int32_t>(records) - 1);
    const std::size_t offset = b.size();
    b.i64(0);
    b.end(vxr);
    Buffer values;
    values.bytes.reserve(8 * records);
    if (time) {
      for (std::int64_t t : var.times) values.data(static_cast<std::uint64_t>(t), big);
    } else {
      for (double x : var.values) values.real(x, big);
    }
    if (content.gzip_variables) {
      const std::vector<std::uint8_t> packed = gzip(values.bytes);
      const std::size_t cvvr = b.begin(kCvvr);
      b.patch64(offset, static_cast<std::int64_t>(cvvr));
      b.i32(0);  // rfuA
      b.i64(static_cast<std::int64_t>(packed.size()));
      b.bytes.insert(b.bytes.end(), packed.begin(), packed.end());
      b.end(cvvr);
      b.patch64(cpr_offset, static_cast<std::int64_t>(write_gzip_cpr(b)));
    } else {
      const std::size_t vvr = b.begin(kVvr);
      b.patch64(offset, static_cast<std::int64_t>(vvr));
      b.bytes.insert(b.bytes.end(), values.bytes.begin(), values.bytes.end());
      b.end(vvr);
    }
  }
  b.patch64(gdr_eof, static_cast<std::int64_t>(b.size()));
  if (!content.gzip_file) return std::move(b.bytes);
  // Whole file: magic numbers (second one 0xCCCC0001), CCR with the gzip of everything after the
  // magic numbers, then the CPR.
  const std::vector<std::uint8_t> packed = gzip(std::vector<std::uint8_t>(b.bytes.begin() + 8, b.bytes.end()));
  Buffer c;
  c.v3 = b.v3;
  c.bytes = {b.bytes[0], b.bytes[1], b.bytes[2], b.bytes[3], 0xCC, 0xCC, 0x00, 0x01};
  const std::size_t ccr = c.begin(kCcr);
  const std::size_t ccr_cpr = c.size();
  c.i64(0);
  c.i64(static_cast<std::int64_t>(b.size() - 8));  // uncompressed size
  c.i32(0);
  c.bytes.insert(c.bytes.end(), packed.begin(), packed.end());
  c.end(ccr);
  c.patch64(ccr_cpr, static_cast<std::int64_t>(write_gzip_cpr(c)));
  return std::move(c.bytes);
}

void write_cdf(const std::string& path, const CdfWriteContent& content) {
  const std::vector<std::uint8_t> bytes = encode_cdf(content);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw InputError(path, "cannot write");
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) throw InputError(path, "write failed");
}

}  // namespace magnetometer_insitu_calibration
