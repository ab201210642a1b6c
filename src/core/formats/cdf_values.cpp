// CDF variable values: the index (VXR, nested), plain (VVR) and GZIP-compressed (CVVR) data
// records, decoding in the file's encoding; see cdf_file.hpp.
#include "magnetometer_insitu_calibration/formats/cdf_file.hpp"

#include "cdf_bytes.hpp"

#include <zlib.h>

#include <algorithm>
#include <limits>

namespace magnetometer_insitu_calibration {

using namespace cdf_detail;

std::vector<std::uint8_t> cdf_inflate(const std::uint8_t* data, std::size_t size, std::size_t expected,
                                      const std::string& name, const std::string& what) {
  std::vector<std::uint8_t> out(expected);
  z_stream z{};
  if (inflateInit2(&z, 15 + 32) != Z_OK) throw InputError(name, what + ": zlib initialisation failed");
  z.next_in = const_cast<Bytef*>(data);
  z.avail_in = static_cast<uInt>(std::min<std::size_t>(size, std::numeric_limits<uInt>::max()));
  z.next_out = out.data();
  z.avail_out = static_cast<uInt>(expected);
  const int rc = inflate(&z, Z_FINISH);
  const std::size_t produced = expected - z.avail_out;
  const std::string message = z.msg ? z.msg : "";
  inflateEnd(&z);
  if (rc == Z_STREAM_END && produced == expected) return out;
  if (rc == Z_STREAM_END || (rc == Z_BUF_ERROR && z.avail_out == 0)) {
    throw InputError(name, what + ": GZIP stream " + (rc == Z_STREAM_END ? "gives " + std::to_string(produced) : "gives more than " + std::to_string(expected)) +
                               " bytes, " + std::to_string(expected) + " expected (corrupt file)");
  }
  if (rc == Z_BUF_ERROR) throw InputError(name, what + ": GZIP stream ends early (truncated file)");
  throw InputError(name, what + ": corrupt GZIP stream" + (message.empty() ? "" : " (" + message + ")"));
}

void CdfFile::read_index(const CdfVariable& variable, std::uint64_t vxr, int depth, std::size_t record_bytes,
                         std::vector<std::uint8_t>& bytes, std::vector<bool>& stored, std::uint64_t& work) const {
  const bool v3 = version_ == 3;
  const std::string part = "index (VXR) of variable " + variable.name;
  if (depth > 8) throw InputError(name_, "CDF " + part + at_byte(vxr) + ": nested more than 8 levels (corrupt file)");
  int lists = 0;
  while (vxr != 0) {
    if (++lists > (1 << 16) || (work += 1024) > 4 * kMaxBytes) throw InputError(name_, "CDF " + part + ": endless list (corrupt file)");
    Cursor c = open_record(bytes_, vxr, v3, name_, part, kVxr);
    const std::uint64_t next = c.offset();
    const std::int32_t entries = c.count("Nentries", 1 << 20);
    const std::int32_t used = c.i32();
    if (used < 0 || used > entries) c.fail("NusedEntries " + std::to_string(used) + " out of range");
    Cursor first_list = c;
    c.skip(4u * static_cast<std::uint64_t>(entries));
    Cursor last_list = c;
    c.skip(4u * static_cast<std::uint64_t>(entries));
    Cursor offsets = c;
    for (std::int32_t i = 0; i < used; ++i) {
      const std::int32_t first = first_list.i32(), last = last_list.i32();
      const std::uint64_t offset = offsets.offset();
      if (first < 0 || last < first) {
        c.fail("entry " + std::to_string(i) + ": records " + std::to_string(first) + " to " + std::to_string(last));
      }
      Cursor probe(bytes_, offset, v3, name_, part);
      if (offset < 8 || offset >= bytes_.size()) c.fail("entry " + std::to_string(i) + " points outside the file");
      probe.offset();
      const std::int32_t type = probe.i32();
      if (type == kVxr) {
        read_index(variable, offset, depth + 1, record_bytes, bytes, stored, work);
        continue;
      }
      const std::uint64_t n = static_cast<std::uint64_t>(last - first) + 1;
      const std::uint64_t end_bytes = (static_cast<std::uint64_t>(last) + 1) * record_bytes;
      if (end_bytes > kMaxBytes) c.fail("records up to " + std::to_string(last) + " exceed the 256 MiB limit");
      if (bytes.size() < end_bytes) {
        bytes.resize(end_bytes);
        stored.resize(static_cast<std::size_t>(last) + 1, false);
      }
      std::uint8_t* dest = bytes.data() + static_cast<std::size_t>(first) * record_bytes;
      const std::size_t want = static_cast<std::size_t>(n * record_bytes);
      work += want + 1024;  // bytes copied or inflated, plus a cost per entry: overlapping entries are corrupt
      if (work > 4 * kMaxBytes) c.fail("entries overlap beyond reason (corrupt file)");
      if (type == kVvr) {
        std::uint64_t size = 0;
        Cursor vvr = open_record(bytes_, offset, v3, name_, "values (VVR) of variable " + variable.name, kVvr, &size);
        if (size - (vvr.pos() - offset) < want) {
          vvr.fail("holds " + std::to_string(size - (vvr.pos() - offset)) + " bytes, records " + std::to_string(first) +
                   " to " + std::to_string(last) + " need " + std::to_string(want) + " (corrupt file)");
        }
        std::copy_n(vvr.data(want), want, dest);
      } else if (type == kCvvr) {
        if (!variable.compressed) c.fail("compressed values (CVVR) in a variable not flagged as compressed");
        std::uint64_t size = 0;
        Cursor cv = open_record(bytes_, offset, v3, name_, "compressed values (CVVR) of variable " + variable.name, kCvvr, &size);
        cv.i32();  // rfuA
        const std::uint64_t csize = cv.offset();
        const std::uint8_t* data = cv.data(csize);
        const std::vector<std::uint8_t> plain =
            cdf_inflate(data, static_cast<std::size_t>(csize), want, name_,
                        "CDF compressed values (CVVR) of variable " + variable.name + at_byte(offset));
        std::copy(plain.begin(), plain.end(), dest);
      } else {
        c.fail("entry " + std::to_string(i) + " points to record type " + std::to_string(type) +
               ", not VXR, VVR or CVVR (corrupt file)");
      }
      for (std::uint64_t r = static_cast<std::uint64_t>(first); r <= static_cast<std::uint64_t>(last); ++r) {
        stored[static_cast<std::size_t>(r)] = true;
      }
    }
    vxr = next;
  }
}

void CdfFile::read_raw(const CdfVariable& variable, std::vector<std::uint8_t>& bytes, std::vector<bool>& stored) const {
  const std::size_t element = cdf_type_size(variable.data_type);
  const std::uint64_t record_bytes =
      static_cast<std::uint64_t>(element) * static_cast<std::uint64_t>(variable.num_elems) * variable.values_per_record;
  if (record_bytes == 0 || record_bytes > kMaxBytes) {
    throw InputError(name_, "CDF variable " + variable.name + ": record of " + std::to_string(record_bytes) + " bytes");
  }
  bytes.clear();
  stored.clear();
  std::uint64_t work = 0;
  read_index(variable, variable.vxr_head, 0, static_cast<std::size_t>(record_bytes), bytes, stored, work);
}

std::vector<double> CdfFile::read_real(const CdfVariable& variable) const {
  if (variable.data_type == kCdfChar || variable.data_type == kCdfUchar) {
    throw InputError(name_, "CDF variable " + variable.name + ": characters, not numbers");
  }
  std::vector<std::uint8_t> raw;
  std::vector<bool> stored;
  read_raw(variable, raw, stored);
  const std::size_t element = cdf_type_size(variable.data_type);
  const std::size_t per_record = variable.values_per_record * static_cast<std::size_t>(variable.num_elems);
  const std::size_t stride = variable.data_type == kCdfEpoch16 ? 16 : element;
  std::vector<double> out(stored.size() * per_record, std::numeric_limits<double>::quiet_NaN());
  for (std::size_t r = 0; r < stored.size(); ++r) {
    if (!stored[r]) continue;
    for (std::size_t k = 0; k < per_record; ++k) {
      const std::size_t i = r * per_record + k;
      out[i] = decode_real(raw.data() + i * stride, variable.data_type, little_endian_);
    }
  }
  return out;
}

std::vector<std::int64_t> CdfFile::read_int64(const CdfVariable& variable) const {
  if (variable.data_type != kCdfInt8 && variable.data_type != kCdfTimeTt2000) {
    throw InputError(name_, "CDF variable " + variable.name + ": data type " + std::to_string(variable.data_type) +
                                ", not INT8 or TIME_TT2000");
  }
  std::vector<std::uint8_t> raw;
  std::vector<bool> stored;
  read_raw(variable, raw, stored);
  const std::size_t per_record = variable.values_per_record * static_cast<std::size_t>(variable.num_elems);
  std::vector<std::int64_t> out(stored.size() * per_record, std::numeric_limits<std::int64_t>::min());
  for (std::size_t r = 0; r < stored.size(); ++r) {
    if (!stored[r]) continue;
    for (std::size_t k = 0; k < per_record; ++k) {
      const std::size_t i = r * per_record + k;
      out[i] = static_cast<std::int64_t>(load(raw.data() + 8 * i, 8, little_endian_));
    }
  }
  return out;
}

}  // namespace magnetometer_insitu_calibration
