// NASA Common Data Format (CDF 2.6 to 3.x): the internal records, read by the package's own code
// (no CDF library is packaged in Debian 12). Covers what observatory archives use: the CDR and
// GDR, attributes (ADR, AEDR), rVariables and zVariables (VDR), their index and data records
// (VXR, VVR), GZIP-compressed variables (CVVR + CPR) and whole-file GZIP compression (CCR),
// big- and little-endian IEEE encodings. Not covered (a clear InputError): CDF before 2.6, VAX
// floating point encodings, RLE/Huffman compression, sparse arrays.
//
// Internal record headers are big-endian (XDR) whatever the data encoding; offsets are 8 bytes
// in CDF 3 and 4 bytes in CDF 2. Every offset and size is checked against the file before use:
// a truncated or corrupt file throws InputError(file, "CDF <part> at byte <offset>: <problem>").
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// CDF data type codes.
enum CdfDataType : int {
  kCdfInt1 = 1, kCdfInt2 = 2, kCdfInt4 = 4, kCdfInt8 = 8,
  kCdfUint1 = 11, kCdfUint2 = 12, kCdfUint4 = 14,
  kCdfReal4 = 21, kCdfReal8 = 22,
  kCdfEpoch = 31,    ///< double, milliseconds since 0000-01-01T00:00:00, no leap seconds
  kCdfEpoch16 = 32,  ///< two doubles: seconds since 0000-01-01, picoseconds
  kCdfTimeTt2000 = 33,  ///< int64, nanoseconds since J2000 (2000-01-01T12:00:00 TT), leap seconds counted
  kCdfByte = 41, kCdfFloat = 44, kCdfDouble = 45, kCdfChar = 51, kCdfUchar = 52,
};

/// Bytes of one element of `type`; 0 for an unknown type.
std::size_t cdf_type_size(int type);

/// One attribute entry: characters in `text` (CDF_CHAR, CDF_UCHAR); numbers otherwise, in
/// `numbers` (as double) and, for the 8-byte integer types (INT8, TT2000), exactly in `integers`.
struct CdfAttributeEntry {
  int data_type = 0;
  std::string text;
  std::vector<double> numbers;
  std::vector<std::int64_t> integers;
  bool is_text() const { return data_type == kCdfChar || data_type == kCdfUchar; }
};

struct CdfVariable {
  std::string name;
  bool z = true;                   ///< zVariable (else rVariable)
  int number = 0;                  ///< within its kind (z or r)
  int data_type = 0;
  int num_elems = 1;               ///< elements per value (characters for CDF_CHAR)
  std::vector<std::int32_t> dims;  ///< dimension sizes
  std::size_t values_per_record = 1;  ///< product of the varying dimensions' sizes
  bool record_variance = true;
  std::int32_t max_rec = -1;       ///< last record written, -1 for none
  std::map<std::string, CdfAttributeEntry> attributes;  ///< variable-scope attributes (FILLVAL, DEPEND_0, ...)
  // Where the values are (file offsets in the uncompressed file).
  std::uint64_t vxr_head = 0;
  bool compressed = false;
};

class CdfFile {
 public:
  /// Reads and checks the whole file (decompressed when whole-file compressed).
  /// Throws InputError(path, ...) for a missing, truncated, corrupt or unsupported file.
  static CdfFile open(const std::string& path);
  /// The same from bytes in memory; `name` is used in the messages.
  static CdfFile parse(std::vector<std::uint8_t> bytes, const std::string& name);

  const std::string& name() const { return name_; }
  int version() const { return version_; }   ///< e.g. 3
  int release() const { return release_; }   ///< e.g. 9
  bool little_endian() const { return little_endian_; }
  bool file_compressed() const { return file_compressed_; }

  /// Global attributes: every entry, in entry-number order.
  const std::map<std::string, std::vector<CdfAttributeEntry>>& global_attributes() const { return global_; }
  /// A global attribute's entries joined by '\n' (numbers: the shortest %.15g..%.17g that reads
  /// back exactly, several in one entry separated by spaces); "" if absent.
  std::string global_text(const std::string& attribute) const;

  const std::vector<CdfVariable>& variables() const { return variables_; }
  /// nullptr when there is no variable of that name (z or r).
  const CdfVariable* find(const std::string& variable) const;

  /// Every value of a numeric variable as double, record after record (values_per_record each),
  /// for records 0 .. the last record stored; a record not stored is NaN. INT8 and TT2000 lose
  /// precision beyond 2^53: use read_int64 for them. Throws InputError for a character variable,
  /// an unknown type, a corrupt index or data record, or an unsupported compression.
  std::vector<double> read_real(const CdfVariable& variable) const;
  /// The same for INT8 and TIME_TT2000, exactly; a record not stored is INT64_MIN (the TT2000 fill).
  std::vector<std::int64_t> read_int64(const CdfVariable& variable) const;

 private:
  /// Raw element bytes, in the file's encoding, for records 0..n-1 (record_bytes each), and
  /// whether each record is stored.
  void read_raw(const CdfVariable& variable, std::vector<std::uint8_t>& bytes, std::vector<bool>& stored) const;
  void read_index(const CdfVariable& variable, std::uint64_t vxr, int depth, std::size_t record_bytes,
                  std::vector<std::uint8_t>& bytes, std::vector<bool>& stored, std::uint64_t& work) const;

  std::string name_;
  std::vector<std::uint8_t> bytes_;  ///< the uncompressed file
  int version_ = 0, release_ = 0;
  bool little_endian_ = false;
  bool file_compressed_ = false;
  std::map<std::string, std::vector<CdfAttributeEntry>> global_;
  std::vector<CdfVariable> variables_;
};

/// GZIP (or zlib) inflation of `size` bytes at `data` into exactly `expected` bytes; throws
/// InputError(name, what + ": ...") when the stream is corrupt or does not give that size.
std::vector<std::uint8_t> cdf_inflate(const std::uint8_t* data, std::size_t size, std::size_t expected,
                                      const std::string& name, const std::string& what);

}  // namespace magnetometer_insitu_calibration
