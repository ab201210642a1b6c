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

/// The file being parsed: its bytes (the uncompressed file once the CCR is read), whether it is
/// CDF 3 (8-byte offsets, 256-character names) or CDF 2 (4-byte offsets, 64-character names), and
/// its name for the messages.
struct CdfView {
  const std::vector<std::uint8_t>& bytes;
  bool v3;
  const std::string& name;
  std::size_t name_length() const { return v3 ? 256 : 64; }
  Cursor record(std::uint64_t offset, const std::string& part, std::int32_t type,
                std::uint64_t* size = nullptr) const {
    return open_record(bytes, offset, v3, name, part, type, size);
  }
};

/// The two magic words: CDF 3 or 2.6, whole-file compressed (CCR) or not.
struct MagicWords {
  bool v3 = true;
  bool compressed = false;
};

MagicWords read_magic_words(const std::vector<std::uint8_t>& bytes, const std::string& name) {
  if (bytes.size() < 8) throw InputError(name, "CDF magic number: file shorter than 8 bytes (truncated)");
  const std::uint32_t magic1 = be32(bytes, 0), magic2 = be32(bytes, 4);
  if (magic1 != kMagicV3 && magic1 != kMagicV26) {
    char b[96];
    std::snprintf(b, sizeof b, "CDF magic number: 0x%08X is not CDF 2.6 (0xCDF26002) or 3.x (0xCDF30001)", magic1);
    throw InputError(name, b);
  }
  if (magic2 != kCompressed && magic2 != kUncompressed) {
    char b[96];
    std::snprintf(b, sizeof b, "CDF magic number: second word 0x%08X is neither 0x0000FFFF nor 0xCCCC0001", magic2);
    throw InputError(name, b);
  }
  return MagicWords{magic1 == kMagicV3, magic2 == kCompressed};
}

/// Checks that the CPR at `offset` names GZIP (the only compression read); `part` names it in
/// the messages.
void require_gzip_cpr(const CdfView& file, std::uint64_t offset, const std::string& part) {
  Cursor cpr = file.record(offset, part, kCpr);
  const std::int32_t ctype = cpr.i32();
  if (ctype != kGzip) {
    cpr.fail("compression type " + std::to_string(ctype) + " is not supported (GZIP, type 5, only)");
  }
}

/// A whole-file compressed CDF as the uncompressed file: its magic numbers with the second one
/// 0x0000FFFF, then the inflated stream of the CCR.
std::vector<std::uint8_t> inflate_whole_file(const CdfView& file) {
  // CCR at byte 8: size, type, CPR offset, uncompressed size (file without the 8 magic bytes),
  // reserved, then the compressed stream; the CPR names the algorithm.
  std::uint64_t ccr_size = 0;
  Cursor ccr = file.record(8, "compressed-file record (CCR)", kCcr, &ccr_size);
  const std::uint64_t cpr_offset = ccr.offset();
  const std::uint64_t usize = ccr.offset();  // bytes
  ccr.i32();
  const std::uint64_t header = ccr.pos() - 8;
  if (usize > kMaxBytes) ccr.fail("uncompressed size " + std::to_string(usize) + " bytes is above the 256 MiB limit");
  require_gzip_cpr(file, cpr_offset, "compression parameters (CPR)");
  std::vector<std::uint8_t> inflated =
      cdf_inflate(file.bytes.data() + ccr.pos(), ccr_size - header, usize, file.name, "CDF compressed file (CCR)");
  std::vector<std::uint8_t> whole(8 + inflated.size());
  std::copy(file.bytes.begin(), file.bytes.begin() + 4, whole.begin());
  whole[4] = whole[5] = 0x00, whole[6] = whole[7] = 0xFF;
  std::copy(inflated.begin(), inflated.end(), whole.begin() + 8);
  return whole;
}

/// What the CDR holds that the rest needs.
struct FileDescriptor {
  std::uint64_t gdr_offset = 0;  ///< byte offset of the GDR
  int version = 0, release = 0;
  bool little_endian = false;    ///< data encoding
};

/// The CDR, at byte 8; checks the version against the magic number and the encoding.
FileDescriptor read_cdr(const CdfView& file) {
  Cursor cdr = file.record(8, "descriptor (CDR)", kCdr);
  FileDescriptor d;
  d.gdr_offset = cdr.offset();
  d.version = cdr.i32();
  d.release = cdr.i32();
  const std::int32_t encoding = cdr.i32();
  if (d.version != (file.v3 ? 3 : 2) || (!file.v3 && d.release < 6)) {
    cdr.fail("version " + std::to_string(d.version) + "." + std::to_string(d.release) +
             " does not match the magic number (CDF 2.6 to 3.x supported)");
  }
  d.little_endian = little_endian_encoding(encoding, file.name);
  return d;
}

/// What the GDR holds that the rest needs: list heads (byte offsets, 0 for none), counts, and
/// the rVariables' dimension sizes.
struct GlobalDescriptor {
  std::uint64_t rvdr_head = 0, zvdr_head = 0, adr_head = 0;
  std::int32_t nr_vars = 0, num_attr = 0, nz_vars = 0;
  std::vector<std::int32_t> r_dims;
};

GlobalDescriptor read_gdr(const CdfView& file, std::uint64_t offset) {
  Cursor gdr = file.record(offset, "global descriptor (GDR)", kGdr);
  GlobalDescriptor d;
  d.rvdr_head = gdr.offset();
  d.zvdr_head = gdr.offset();
  d.adr_head = gdr.offset();
  gdr.offset();  // eof
  d.nr_vars = gdr.count("rVariable count", kMaxListLength);
  d.num_attr = gdr.count("attribute count", kMaxListLength);
  gdr.i32();  // rMaxRec
  const std::int32_t r_num_dims = gdr.count("rVariable dimension count", 10);
  d.nz_vars = gdr.count("zVariable count", kMaxListLength);
  gdr.offset();  // UIR head
  gdr.skip(12);  // rfuC, leap-second update (rfuD in CDF 2), rfuE
  for (int i = 0; i < r_num_dims; ++i) d.r_dims.push_back(gdr.count("rVariable dimension size", 1 << 24));
  return d;
}

/// One rVDR or zVDR at `offset`; *next receives the next VDR's offset (0 at the end).
CdfVariable read_vdr(const CdfView& file, std::uint64_t offset, bool z, const std::vector<std::int32_t>& r_dims,
                     std::uint64_t* next) {
  const std::string part = std::string(z ? "zVariable" : "rVariable") + " descriptor (" + (z ? "zVDR" : "rVDR") + ")";
  Cursor c = file.record(offset, part, z ? kZvdr : kRvdr);
  CdfVariable v;
  v.z = z;
  *next = c.offset();
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
  v.name = c.text(file.name_length());
  if (z) {
    const std::int32_t n = c.count("zNumDims", 10);
    for (int i = 0; i < n; ++i) v.dims.push_back(c.count("dimension size", 1 << 24));
  } else {
    v.dims = r_dims;
  }
  std::uint64_t per_record = 1;  // values in one record
  for (std::int32_t d : v.dims) {
    const std::int32_t varies = c.i32();
    if (varies != 0) per_record *= static_cast<std::uint64_t>(d);
    if (per_record > kMaxBytes) c.fail("record of " + std::to_string(per_record) + " values is too large");
  }
  v.values_per_record = static_cast<std::size_t>(per_record);
  if (v.compressed) {  // a compressed variable's CPR must be GZIP
    if (cpr_offset <= 0) c.fail("compressed variable " + v.name + " without compression parameters (CPR)");
    require_gzip_cpr(file, static_cast<std::uint64_t>(cpr_offset), "compression parameters (CPR) of variable " + v.name);
  }
  return v;
}

/// The rVDR or zVDR list from `head`, appended to `variables`; checks the GDR's count.
void read_variable_list(const CdfView& file, std::uint64_t head, bool z, std::int32_t expected,
                        const std::vector<std::int32_t>& r_dims, std::vector<CdfVariable>& variables) {
  ListGuard guard(file.name, z ? "zVariable" : "rVariable");
  std::uint64_t offset = head;
  int count = 0;
  while (guard.next(offset)) {
    std::uint64_t next = 0;
    variables.push_back(read_vdr(file, offset, z, r_dims, &next));
    offset = next;
    ++count;
  }
  if (count != expected) {
    throw InputError(file.name, "CDF global descriptor (GDR): " + std::to_string(expected) + " " +
                                    (z ? "zVariables" : "rVariables") + " announced, " + std::to_string(count) +
                                    " found (corrupt file)");
  }
}

/// One AEDR (AgrEDR, or AzEDR when z) of `attribute` at `offset`; *number receives its entry
/// number (the variable's number for a variable attribute), *next the next AEDR's offset.
CdfAttributeEntry read_aedr(const CdfView& file, std::uint64_t offset, bool z, const std::string& attribute,
                            bool little_endian, std::int32_t* number, std::uint64_t* next) {
  Cursor ec = file.record(offset, "entry of attribute " + attribute + " (AEDR)", z ? kAzedr : kAgredr);
  *next = ec.offset();
  ec.i32();  // attribute number
  CdfAttributeEntry entry;
  entry.data_type = ec.i32();
  *number = ec.i32();
  const std::int32_t elems = ec.count("NumElems", 1 << 24);
  ec.skip(20);  // NumStrings, rfuB..rfuE
  const std::size_t size = cdf_type_size(entry.data_type);  // bytes per element
  if (size == 0) ec.fail("unknown data type " + std::to_string(entry.data_type));
  const std::uint8_t* p = ec.data(size * static_cast<std::size_t>(elems));
  if (entry.is_text()) {
    entry.text.assign(reinterpret_cast<const char*>(p), static_cast<std::size_t>(elems));
    entry.text.resize(strnlen(entry.text.c_str(), entry.text.size()));
  } else {
    for (std::int32_t i = 0; i < elems; ++i) {
      const std::uint8_t* q = p + size * static_cast<std::size_t>(i);
      entry.numbers.push_back(decode_real(q, entry.data_type, little_endian));
      if (size == 8 && (entry.data_type == kCdfInt8 || entry.data_type == kCdfTimeTt2000)) {
        entry.integers.push_back(static_cast<std::int64_t>(load(q, 8, little_endian)));
      }
    }
  }
  return entry;
}

/// One ADR at `offset` and its entries: a global attribute's (scope 1, 3) go to `global` in
/// entry-number order, a variable attribute's (scope 2, 4) to the variables they name. Returns
/// the next ADR's offset.
std::uint64_t read_attribute(const CdfView& file, std::uint64_t offset, bool little_endian,
                             std::vector<CdfVariable>& variables,
                             std::map<std::string, std::vector<CdfAttributeEntry>>& global) {
  Cursor c = file.record(offset, "attribute descriptor (ADR)", kAdr);
  const std::uint64_t next = c.offset();
  const std::uint64_t gr_head = c.offset();
  const std::int32_t scope = c.i32();
  c.skip(16);  // Num, NgrEntries, MAXgrEntry, rfuA
  const std::uint64_t z_head = c.offset();
  c.skip(12);  // NzEntries, MAXzEntry, rfuE
  const std::string attribute = c.text(file.name_length());
  const bool is_global = scope == 1 || scope == 3;
  std::map<int, CdfAttributeEntry> global_entries;  // by entry number
  for (const bool z : {false, true}) {
    ListGuard entry_guard(file.name, "attribute " + attribute + " entry");
    std::uint64_t e = z ? z_head : gr_head;
    while (entry_guard.next(e)) {
      std::int32_t number = 0;
      std::uint64_t enext = 0;
      CdfAttributeEntry entry = read_aedr(file, e, z, attribute, little_endian, &number, &enext);
      if (is_global) {
        global_entries[number] = std::move(entry);
      } else {
        for (CdfVariable& v : variables) {
          if (v.z == z && v.number == number) v.attributes[attribute] = entry;
        }
      }
      e = enext;
    }
  }
  if (is_global) {
    std::vector<CdfAttributeEntry>& list = global[attribute];
    for (auto& [number, entry] : global_entries) list.push_back(std::move(entry));
  }
  return next;
}

/// The ADR list from `head`; checks the GDR's attribute count.
void read_attributes(const CdfView& file, std::uint64_t head, std::int32_t expected, bool little_endian,
                     std::vector<CdfVariable>& variables,
                     std::map<std::string, std::vector<CdfAttributeEntry>>& global) {
  ListGuard adr_guard(file.name, "attribute");
  std::uint64_t adr = head;
  int attributes = 0;
  while (adr_guard.next(adr)) {
    adr = read_attribute(file, adr, little_endian, variables, global);
    ++attributes;
  }
  if (attributes != expected) {
    throw InputError(file.name, "CDF global descriptor (GDR): " + std::to_string(expected) + " attributes announced, " +
                                    std::to_string(attributes) + " found (corrupt file)");
  }
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
  const MagicWords magic = read_magic_words(bytes, name);
  if (magic.compressed) {
    bytes = inflate_whole_file(CdfView{bytes, magic.v3, name});
    f.file_compressed_ = true;
  }
  f.bytes_ = std::move(bytes);
  const CdfView file{f.bytes_, magic.v3, name};
  const FileDescriptor cdr = read_cdr(file);
  f.version_ = cdr.version;
  f.release_ = cdr.release;
  f.little_endian_ = cdr.little_endian;
  const GlobalDescriptor gdr = read_gdr(file, cdr.gdr_offset);
  // Variable descriptors, r then z; the attributes' variable entries are attached afterwards.
  read_variable_list(file, gdr.rvdr_head, false, gdr.nr_vars, gdr.r_dims, f.variables_);
  read_variable_list(file, gdr.zvdr_head, true, gdr.nz_vars, gdr.r_dims, f.variables_);
  read_attributes(file, gdr.adr_head, gdr.num_attr, f.little_endian_, f.variables_, f.global_);
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
