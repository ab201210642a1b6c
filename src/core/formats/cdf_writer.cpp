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

/// Byte offset of a record's next-pointer, after its size and type.
std::size_t next_pointer_at(const Buffer& b) { return b.v3 ? 12 : 8; }

/// The CDR (version 3.9.0 or 2.7.0, row major + single file, encoding NETWORK (1) or IBMPC (6));
/// returns where the GDR's offset goes.
std::size_t write_cdr(Buffer& b, bool big_endian) {
  const std::size_t cdr = b.begin(kCdr);
  const std::size_t cdr_gdr = b.size();
  b.i64(0);
  b.i32(b.v3 ? 3 : 2), b.i32(b.v3 ? 9 : 7), b.i32(big_endian ? 1 : 6), b.i32(3), b.i32(0), b.i32(0), b.i32(0),
      b.i32(-1), b.i32(-1);
  std::string copyright = "Common Data Format (CDF)\nwritten by magnetometer_insitu_calibration\n";
  copyright.resize(256, '\0');
  b.bytes.insert(b.bytes.end(), copyright.begin(), copyright.end());
  b.end(cdr);
  return cdr_gdr;
}

/// The variable attributes' names in order of first use; throws for a data type not written.
std::vector<std::string> variable_attribute_names(const CdfWriteContent& content) {
  std::vector<std::string> names;
  for (const CdfWriteVariable& v : content.variables) {
    if (v.data_type != kCdfDouble && v.data_type != kCdfTimeTt2000 && v.data_type != kCdfEpoch) {
      throw InputError("CDF writer", "variable " + v.name + ": data type " + std::to_string(v.data_type) + " not written");
    }
    for (const auto& [name, entry] : v.attributes) {
      if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
    }
  }
  return names;
}

/// Where the GDR's zVDR head, ADR head and end-of-file offsets are written.
struct GdrSlots {
  std::size_t zvdr_head = 0, adr_head = 0, eof = 0;
};

/// The GDR, its offset patched into the CDR at `cdr_gdr`; the list heads and EOF are patched later.
GdrSlots write_gdr(Buffer& b, const CdfWriteContent& content, std::size_t cdr_gdr,
                   std::size_t variable_attribute_count) {
  const std::size_t gdr = b.begin(kGdr);
  b.patch64(cdr_gdr, static_cast<std::int64_t>(gdr));
  b.i64(0);  // rVDR head
  GdrSlots slots;
  slots.zvdr_head = b.size();
  b.i64(0);
  slots.adr_head = b.size();
  b.i64(0);
  slots.eof = b.size();
  b.i64(0);
  const auto attribute_count = static_cast<std::int32_t>(content.global.size() + variable_attribute_count);
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
  return slots;
}

/// Where an ADR's AgrEDR and AzEDR list heads are written.
struct AdrHeads {
  std::size_t gr_head = 0, z_head = 0;
};

/// One ADR (attribute number `number`), linked from the offset slot at `previous_next`, which
/// then becomes this ADR's next-pointer.
AdrHeads write_adr(Buffer& b, std::size_t& previous_next, const std::string& name, std::int32_t number,
                   std::int32_t scope, std::int32_t gr_entries, std::int32_t z_entries, std::int32_t max_z) {
  const std::size_t adr = b.begin(kAdr);
  b.patch64(previous_next, static_cast<std::int64_t>(adr));
  previous_next = b.size();
  b.i64(0);  // next ADR
  AdrHeads heads;
  heads.gr_head = b.size();
  b.i64(0);
  b.i32(scope), b.i32(number), b.i32(gr_entries), b.i32(gr_entries - 1), b.i32(0);
  heads.z_head = b.size();
  b.i64(0);
  b.i32(z_entries), b.i32(max_z), b.i32(0);
  b.name(name);
  b.end(adr);
  return heads;
}

/// Every ADR with its AEDRs: global attributes (scope 1), then variable ones (scope 2, one
/// AzEDR per variable that has it, numbered by the variable), linked from the GDR's `gdr_adr`.
void write_attributes(Buffer& b, const CdfWriteContent& content, const std::vector<std::string>& variable_attributes,
                      std::size_t gdr_adr) {
  const bool big = content.big_endian;
  const std::size_t next_at = next_pointer_at(b);
  std::size_t previous_next = gdr_adr;  // where the next ADR's offset goes
  std::int32_t number = 0;
  for (const auto& [name, entries] : content.global) {
    const AdrHeads heads = write_adr(b, previous_next, name, number, 1, static_cast<std::int32_t>(entries.size()), 0, -1);
    std::size_t link = heads.gr_head;
    for (std::size_t e = 0; e < entries.size(); ++e) {
      const std::size_t aedr = write_entry(b, kAgredr, number, static_cast<std::int32_t>(e), entries[e], big);
      b.patch64(link, static_cast<std::int64_t>(aedr));
      link = aedr + next_at;
    }
    ++number;
  }
  for (const std::string& name : variable_attributes) {
    std::map<std::int32_t, const CdfWriteEntry*> entries;  // by variable number
    for (std::size_t v = 0; v < content.variables.size(); ++v) {
      for (const auto& [attribute, entry] : content.variables[v].attributes) {
        if (attribute == name) entries[static_cast<std::int32_t>(v)] = &entry;
      }
    }
    const AdrHeads heads = write_adr(b, previous_next, name, number, 2, 0, static_cast<std::int32_t>(entries.size()),
                                     entries.rbegin()->first);
    std::size_t link = heads.z_head;
    for (const auto& [variable, entry] : entries) {
      const std::size_t aedr = write_entry(b, kAzedr, number, variable, *entry, big);
      b.patch64(link, static_cast<std::int64_t>(aedr));
      link = aedr + next_at;
    }
    ++number;
  }
}

/// Where a zVDR's VXR head (and tail, just after) and its CPR offset are written.
struct ZvdrSlots {
  std::size_t vxr_head = 0, cpr_offset = 0;
};

/// The zVDR of variable number `number` with `records` records, linked from `previous_next`,
/// which then becomes this zVDR's next-pointer.
ZvdrSlots write_zvdr(Buffer& b, std::size_t& previous_next, const CdfWriteVariable& var, std::size_t number,
                     std::size_t records, bool gzip_variables) {
  const std::size_t vdr = b.begin(kZvdr);
  b.patch64(previous_next, static_cast<std::int64_t>(vdr));
  previous_next = b.size();
  b.i64(0);  // next VDR
  b.i32(var.data_type);
  b.i32(static_cast<std::int32_t>(records) - 1);  // MaxRec
  ZvdrSlots slots;
  slots.vxr_head = b.size();
  b.i64(0), b.i64(0);  // VXR head, tail
  b.i32(gzip_variables ? 5 : 1);            // flags: record variance, compressed
  b.i32(0), b.i32(0), b.i32(0), b.i32(-1);  // SRecords, rfuB, rfuC, rfuF
  b.i32(1);                                 // NumElems
  b.i32(static_cast<std::int32_t>(number)); // Num
  slots.cpr_offset = b.size();
  b.i64(-1);                                // CPR/SPR offset: none until a CPR is written
  b.i32(0);                                 // blocking factor
  b.name(var.name);
  b.i32(0);  // zNumDims
  b.end(vdr);
  return slots;
}

/// A variable's VXR (one entry: records 0 .. records-1) and its values in one VVR, or in one
/// CVVR followed by its CPR when `gzip_variables`.
void write_values(Buffer& b, const ZvdrSlots& slots, const CdfWriteVariable& var, std::size_t records,
                  bool gzip_variables, bool big) {
  const std::size_t vxr = b.begin(kVxr);
  b.patch64(slots.vxr_head, static_cast<std::int64_t>(vxr));
  b.patch64(slots.vxr_head + b.offset_size(), static_cast<std::int64_t>(vxr));
  b.i64(0);        // next VXR
  b.i32(1), b.i32(1);  // Nentries, NusedEntries
  b.i32(0), b.i32(static_cast<std::int32_t>(records) - 1);
  const std::size_t offset = b.size();
  b.i64(0);
  b.end(vxr);
  Buffer values;
  values.bytes.reserve(8 * records);
  if (var.data_type == kCdfTimeTt2000) {
    for (std::int64_t t : var.times) values.data(static_cast<std::uint64_t>(t), big);
  } else {
    for (double x : var.values) values.real(x, big);
  }
  if (gzip_variables) {
    const std::vector<std::uint8_t> packed = gzip(values.bytes);
    const std::size_t cvvr = b.begin(kCvvr);
    b.patch64(offset, static_cast<std::int64_t>(cvvr));
    b.i32(0);  // rfuA
    b.i64(static_cast<std::int64_t>(packed.size()));
    b.bytes.insert(b.bytes.end(), packed.begin(), packed.end());
    b.end(cvvr);
    b.patch64(slots.cpr_offset, static_cast<std::int64_t>(write_gzip_cpr(b)));
  } else {
    const std::size_t vvr = b.begin(kVvr);
    b.patch64(offset, static_cast<std::int64_t>(vvr));
    b.bytes.insert(b.bytes.end(), values.bytes.begin(), values.bytes.end());
    b.end(vvr);
  }
}

/// Every variable: its zVDR, then (when it has records) its VXR and values; linked from the
/// GDR's `gdr_zvdr`.
void write_variables(Buffer& b, const CdfWriteContent& content, std::size_t gdr_zvdr) {
  std::size_t previous_next = gdr_zvdr;  // where the next zVDR's offset goes
  for (std::size_t v = 0; v < content.variables.size(); ++v) {
    const CdfWriteVariable& var = content.variables[v];
    const bool time = var.data_type == kCdfTimeTt2000;
    const std::size_t records = time ? var.times.size() : var.values.size();
    const ZvdrSlots slots = write_zvdr(b, previous_next, var, v, records, content.gzip_variables);
    if (records == 0) continue;
    write_values(b, slots, var, records, content.gzip_variables, content.big_endian);
  }
}

/// The whole file compressed: magic numbers (second one 0xCCCC0001), CCR with the gzip of
/// everything after the magic numbers, then the CPR.
std::vector<std::uint8_t> compress_whole_file(const Buffer& b) {
  const std::vector<std::uint8_t> packed = gzip(std::vector<std::uint8_t>(b.bytes.begin() + 8, b.bytes.end()));
  Buffer c;
  c.v3 = b.v3;
  c.bytes = {b.bytes[0], b.bytes[1], b.bytes[2], b.bytes[3], 0xCC, 0xCC, 0x00, 0x01};
  const std::size_t ccr = c.begin(kCcr);
  const std::size_t ccr_cpr = c.size();
  c.i64(0);
  c.i64(static_cast<std::int64_t>(b.size() - 8));  // uncompressed size, bytes
  c.i32(0);
  c.bytes.insert(c.bytes.end(), packed.begin(), packed.end());
  c.end(ccr);
  c.patch64(ccr_cpr, static_cast<std::int64_t>(write_gzip_cpr(c)));
  return std::move(c.bytes);
}

}  // namespace

std::vector<std::uint8_t> encode_cdf(const CdfWriteContent& content) {
  if (content.version != 2 && content.version != 3) throw InputError("CDF writer", "version 2 (2.7) or 3 (3.9) only");
  Buffer b;
  b.v3 = content.version == 3;
  b.bytes = b.v3 ? std::vector<std::uint8_t>{0xCD, 0xF3, 0x00, 0x01, 0x00, 0x00, 0xFF, 0xFF}
                 : std::vector<std::uint8_t>{0xCD, 0xF2, 0x60, 0x02, 0x00, 0x00, 0xFF, 0xFF};
  const std::size_t cdr_gdr = write_cdr(b, content.big_endian);
  // Attributes: the global ones, then the variable ones in order of first use.
  const std::vector<std::string> variable_attributes = variable_attribute_names(content);
  const GdrSlots gdr = write_gdr(b, content, cdr_gdr, variable_attributes.size());
  write_attributes(b, content, variable_attributes, gdr.adr_head);
  write_variables(b, content, gdr.zvdr_head);
  b.patch64(gdr.eof, static_cast<std::int64_t>(b.size()));
  if (!content.gzip_file) return std::move(b.bytes);
  return compress_whole_file(b);
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
