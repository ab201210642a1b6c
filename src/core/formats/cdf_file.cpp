// CDF file structure: magic numbers, whole-file compression (CCR/CPR), CDR, GDR, attributes
// (ADR/AEDR) and variable descriptors (rVDR/zVDR); see cdf_file.hpp. Values: cdf_values.cpp.
#include "magnetometer_insitu_calibration/formats/cdf_file.hpp"

#include "cdf_bytes.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <set>

namespace magnetometer_insitu_calibration {

using namespace cdf_detail;

namespace {

constexpr std::uint32_t kMagicV3 = 0xCDF30001u, kMagicV26 = 0xCDF26002u;
constexpr std::uint32_t kUncompressed = 0x0000FFFFu, kCompressed = 0xCCCC0001u;
constexpr int kMaxListLength = 1 << 16;  // attributes, entries, variables: more is a corrupt list

std::uint32_t be32(const std::vector<std::uint8_t>& b, std::size_t p) {
  return (std::uint32_t{b[p]} << 24) | (std::uint32_t{b[p + 1]} << 16) | (std::uint32_t{b[p + 2]} << 8) | b[p + 3];
}

/// Encodings with IEEE floating point: true for little endian; throws for VAX and unknown ones.
bool little_endian_encoding(std::int32_t encoding, const std::string& name) {
  switch (encoding) {
    case 1: case 2: case 5: case 7: case 9: case 11: case 12:  // network, SUN, SGi, IBMRS, PPC, HP, NeXT
      return false;
    case 4: case 6: case 13: case 16:  // DECSTATION, IBMPC, ALPHAOSF1, ALPHAVMSi
      return true;
    case 3: case 14: case 15:
      throw InputError(name, "CDF descriptor: VAX floating-point encoding " + std::to_string(encoding) +
                                 " is not supported (IEEE encodings only)");
    default:
      throw InputError(name, "CDF descriptor: unknown data encoding " + std::to_string(encoding));
  }
}

/// Follows a linked list of records safely: stops at offset 0, refuses a loop or an endless list.
class ListGuard {
 public:
  ListGuard(const std::string& name, std::string what) : name_(name), what_(std::move(what)) {}
  bool next(std::uint64_t offset) {
    if (offset == 0) return false;
    if (!seen_.insert(offset).second || seen_.size() > kMaxListLength) {
      throw InputError(name_, "CDF " + what_ + " list loops" + at_byte(offset) + " (corrupt file)");
    }
    return true;
  }

 private:
  const std::string& name_;
  std::string what_;
  std::set<std::uint64_t> seen_;
};

/// The shortest of %.15g, %.16g, %.17g that reads back as v.
std::string number_text(double v) {
  char b[40];
  for (int digits = 15; digits <= 17; ++digits) {
    std::snprintf(b, sizeof b, "%.*g", digits, v);
    if (std::strtod(b, nullptr) == v) break;
  }
  return b;
}

}  // namespace

std::size_t cdf_type_size(int type) {
  switch (type) {
    case 1: case 11: case 41: case 51: case 52: return 1;
    case 2: case 12: return 2;
    case 4: case 14: case 21: case 44: return 4;
    case 8: case 22: case 31: case 33: case 45: return 8;
    case 32: return 16;
    default: return 0;
  }
}

CdfFile CdfFile::open(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "cannot open");
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw InputError(path, "read error");
  return parse(std::move(bytes), path);
}

CdfFile CdfFile::parse(std::vector<std::uint8_t> bytes, const std::string& name) {
  CdfFile f;
  f.name_ = name;
  if (bytes.size() < 8) throw InputError(name, "CDF magic number: file shorter than 8 bytes (truncated)");
  const std::uint32_t magic1 = be32(bytes, 0), magic2 = be32(bytes, 4);
  if (magic1 != kMagicV3 && magic1 != kMagicV26) {
    char b[96];
    std::snprintf(b, sizeof b, "CDF magic number: 0x%08X is not CDF 2.6 (0xCDF26002) or 3.x (0xCDF30001)", magic1);
    throw InputError(name, b);
  }
  const bool v3 = magic1 == kMagicV3;
  if (magic2 == kCompressed) {
    // CCR at byte 8: size, type, CPR offset, uncompressed size (file without the 8 magic bytes),
    // reserved, then the compressed stream; the CPR names the algorithm.
    std::uint64_t ccr_size = 0;
    Cursor ccr = open_record(bytes, 8, v3, name, "compressed-file record (CCR)", kCcr, &ccr_size);
    const std::uint64_t cpr_offset = ccr.offset();
    const std::uint64_t usize = ccr.offset();
    ccr.i32();
    const std::uint64_t header = ccr.pos() - 8;
    if (usize > kMaxBytes) ccr.fail("uncompressed size " + std::to_string(usize) + " bytes is above the 256 MiB limit");
    Cursor cpr = open_record(bytes, cpr_offset, v3, name, "compression parameters (CPR)", kCpr);
    const std::int32_t ctype = cpr.i32();
    if (ctype != kGzip) {
      cpr.fail("compression type " + std::to_string(ctype) + " is not supported (GZIP, type 5, only)");
    }
    std::vector<std::uint8_t> inflated =
        cdf_inflate(bytes.data() + ccr.pos(), ccr_size - header, usize, name, "CDF compressed file (CCR)");
    std::vector<std::uint8_t> whole(8 + inflated.size());
    std::copy(bytes.begin(), bytes.begin() + 4, whole.begin());
    whole[4] = whole[5] = 0x00, whole[6] = whole[7] = 0xFF;
    std::copy(inflated.begin(), inflated.end(), whole.begin() + 8);
    bytes = std::move(whole);
    f.file_compressed_ = true;
  } else if (magic2 != kUncompressed) {
    char b[96];
    std::snprintf(b, sizeof b, "CDF magic number: second word 0x%08X is neither 0x0000FFFF nor 0xCCCC0001", magic2);
    throw InputError(name, b);
  }
  f.bytes_ = std::move(bytes);
  const std::vector<std::uint8_t>& b = f.bytes_;
  const std::size_t name_length = v3 ? 256 : 64;

  // CDR at byte 8.
  Cursor cdr = open_record(b, 8, v3, name, "descriptor (CDR)", kCdr);
  const std::uint64_t gdr_offset = cdr.offset();
  f.version_ = cdr.i32();
  f.release_ = cdr.i32();
  const std::int32_t encoding = cdr.i32();
  if (f.version_ != (v3 ? 3 : 2) || (!v3 && f.release_ < 6)) {
    cdr.fail("version " + std::to_string(f.version_) + "." + std::to_string(f.release_) +
             " does not match the magic number (CDF 2.6 to 3.x supported)");
  }
  f.little_endian_ = little_endian_encoding(encoding, name);

  // GDR.
  Cursor gdr = open_record(b, gdr_offset, v3, name, "global descriptor (GDR)", kGdr);
  const std::uint64_t rvdr_head = gdr.offset(), zvdr_head = gdr.offset(), adr_head = gdr.offset();
  gdr.offset();  // eof
  const std::int32_t nr_vars = gdr.count("rVariable count", kMaxListLength);
  const std::int32_t num_attr = gdr.count("attribute count", kMaxListLength);
  gdr.i32();  // rMaxRec
  const std::int32_t r_num_dims = gdr.count("rVariable dimension count", 10);
  const std::int32_t nz_vars = gdr.count("zVariable count", kMaxListLength);
  gdr.offset();  // UIR head
  gdr.skip(12);  // rfuC, leap-second update (rfuD in CDF 2), rfuE
  std::vector<std::int32_t> r_dims;
  for (int i = 0; i < r_num_dims; ++i) r_dims.push_back(gdr.count("rVariable dimension size", 1 << 24));

  // Variable descriptors, r then z; the attributes' variable entries are attached afterwards.
  auto read_vdrs = [&](std::uint64_t head, bool z, std::int32_t expected) {
    ListGuard guard(name, z ? "zVariable" : "rVariable");
    std::uint64_t offset = head;
    int count = 0;
    while (guard.next(offset)) {
      const std::string part = std::string(z ? "zVariable" : "rVariable") + " descriptor (" + (z ? "zVDR" : "rVDR") + ")";
      Cursor c = open_record(b, offset, v3, name, part, z ? kZvdr : kRvdr);
      CdfVariable v;
      v.z = z;
      const std::uint64_t next = c.offset();
      v.data_type = c.i32();
      if (cdf_type_size(v.data_type) == 0) c.fail("unknown data type " + std::to_string(v.data_type));
      v.max_rec = c.i32();
      if (v.max_rec < -1) c.fail("MaxRec " + std::to_string(v.max_rec) + " is negative");
      v.vxr_head = c.offset();
      c.offset();  // VXR tail
      const std::int32_t flags = c.i32();
      v.record_variance = (flags & 1) != 0;
      v.compressed = (flags & 4) != 0;
      c.skip(16);  // SRecords, rfuB, rfuC, rfuF
      v.num_elems = c.count("NumElems", 1 << 20);
      if (v.num_elems < 1) c.fail("NumElems 0");
      v.number = c.i32();
      const std::int64_t cpr_offset = c.raw_offset();  // CPR (compressed), SPR (sparse arrays) or -1
      c.i32();     // blocking factor
      v.name = c.text(name_length);
      if (z) {
        const std::int32_t n = c.count("zNumDims", 10);
        for (int i = 0; i < n; ++i) v.dims.push_back(c.count("dimension size", 1 << 24));
      } else {
        v.dims = r_dims;
      }
      std::uint64_t per_record = 1;
      for (std::int32_t d : v.dims) {
        const std::int32_t varies = c.i32();
        if (varies != 0) per_record *= static_cast<std::uint64_t>(d);
        if (per_record > kMaxBytes) c.fail("record of " + std::to_string(per_record) + " values is too large");
      }
      v.values_per_record = static_cast<std::size_t>(per_record);
      if (v.compressed) {  // a compressed variable's CPR must be GZIP
        if (cpr_offset <= 0) c.fail("compressed variable " + v.name + " without compression parameters (CPR)");
        Cursor cpr = open_record(b, static_cast<std::uint64_t>(cpr_offset), v3, name, "compression parameters (CPR) of variable " + v.name, kCpr);
        const std::int32_t ctype = cpr.i32();
        if (ctype != kGzip) {
          cpr.fail("compression type " + std::to_string(ctype) + " is not supported (GZIP, type 5, only)");
        }
      }
      f.variables_.push_back(std::move(v));
      offset = next;
      ++count;
    }
    if (count != expected) {
      throw InputError(name, "CDF global descriptor (GDR): " + std::to_string(expected) + " " +
                                 (z ? "zVariables" : "rVariables") + " announced, " + std::to_string(count) +
                                 " found (corrupt file)");
    }
  };
  read_vdrs(rvdr_head, false, nr_vars);
  read_vdrs(zvdr_head, true, nz_vars);

  // Attributes: global (scope 1, 3) and variable (scope 2, 4) entries.
  ListGuard adr_guard(name, "attribute");
  std::uint64_t adr = adr_head;
  int attributes = 0;
  while (adr_guard.next(adr)) {
    Cursor c = open_record(b, adr, v3, name, "attribute descriptor (ADR)", kAdr);
    const std::uint64_t next = c.offset();
    const std::uint64_t gr_head = c.offset();
    const std::int32_t scope = c.i32();
    c.skip(16);  // Num, NgrEntries, MAXgrEntry, rfuA
    const std::uint64_t z_head = c.offset();
    c.skip(12);  // NzEntries, MAXzEntry, rfuE
    const std::string attribute = c.text(name_length);
    const bool global = scope == 1 || scope == 3;
    std::map<int, CdfAttributeEntry> global_entries;
    for (const bool z : {false, true}) {
      ListGuard entry_guard(name, "attribute " + attribute + " entry");
      std::uint64_t e = z ? z_head : gr_head;
      while (entry_guard.next(e)) {
        Cursor ec = open_record(b, e, v3, name, "entry of attribute " + attribute + " (AEDR)", z ? kAzedr : kAgredr);
        const std::uint64_t enext = ec.offset();
        ec.i32();  // attribute number
        CdfAttributeEntry entry;
        entry.data_type = ec.i32();
        const std::int32_t number = ec.i32();
        const std::int32_t elems = ec.count("NumElems", 1 << 24);
        ec.skip(20);  // NumStrings, rfuB..rfuE
        const std::size_t size = cdf_type_size(entry.data_type);
        if (size == 0) ec.fail("unknown data type " + std::to_string(entry.data_type));
        const std::uint8_t* p = ec.data(size * static_cast<std::size_t>(elems));
        if (entry.is_text()) {
          entry.text.assign(reinterpret_cast<const char*>(p), static_cast<std::size_t>(elems));
          entry.text.resize(strnlen(entry.text.c_str(), entry.text.size()));
        } else {
          for (std::int32_t i = 0; i < elems; ++i) {
            const std::uint8_t* q = p + size * static_cast<std::size_t>(i);
            entry.numbers.push_back(decode_real(q, entry.data_type, f.little_endian_));
            if (size == 8 && (entry.data_type == kCdfInt8 || entry.data_type == kCdfTimeTt2000)) {
              entry.integers.push_back(static_cast<std::int64_t>(load(q, 8, f.little_endian_)));
            }
          }
        }
        if (global) {
          global_entries[number] = std::move(entry);
        } else {
          for (CdfVariable& v : f.variables_) {
            if (v.z == z && v.number == number) v.attributes[attribute] = entry;
          }
        }
        e = enext;
      }
    }
    if (global) {
      std::vector<CdfAttributeEntry>& list = f.global_[attribute];
      for (auto& [number, entry] : global_entries) list.push_back(std::move(entry));
    }
    adr = next;
    ++attributes;
  }
  if (attributes != num_attr) {
    throw InputError(name, "CDF global descriptor (GDR): " + std::to_string(num_attr) + " attributes announced, " +
                               std::to_string(attributes) + " found (corrupt file)");
  }
  return f;
}

std::string CdfFile::global_text(const std::string& attribute) const {
  const auto it = global_.find(attribute);
  if (it == global_.end()) return "";
  std::string out;
  for (const CdfAttributeEntry& e : it->second) {
    if (!out.empty()) out += '\n';
    if (e.is_text()) {
      out += e.text;
    } else {
      for (std::size_t i = 0; i < e.numbers.size(); ++i) out += (i ? " " : "") + number_text(e.numbers[i]);
    }
  }
  return out;
}

const CdfVariable* CdfFile::find(const std::string& variable) const {
  for (const CdfVariable& v : variables_) {
    if (v.name == variable) return &v;
  }
  return nullptr;
}

}  // namespace magnetometer_insitu_calibration
