// CDF reader on the real WIC MagPy CDF files: the same values as the IAGA-2002 conversion,
// temperatures, and clear errors for truncated, corrupt and unsupported files.
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/cdf_file.hpp"
#include "magnetometer_insitu_calibration/formats/cdf_records.hpp"
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;
using mic::test::contains;
using mic::test::package_data;
using mic::test::test_data;

namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return Bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void write_cdf_file(const std::string& path, const Bytes& bytes) {
  mic::test::write_bytes(path, std::string(bytes.begin(), bytes.end()));
}

std::uint64_t be64(const Bytes& b, std::size_t p) {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | b[p + static_cast<std::size_t>(i)];
  return v;
}

/// The uncompressed CDF of a whole-file compressed CDF 3 (CCR at byte 8: size, type, CPR offset,
/// uncompressed size, 4 reserved bytes, then the gzip stream), inflated here with zlib directly.
Bytes uncompressed_cdf(const Bytes& compressed) {
  const std::uint64_t ccr_size = be64(compressed, 8), usize = be64(compressed, 28);
  Bytes out(8 + usize);
  std::copy_n(compressed.begin(), 4, out.begin());
  out[6] = out[7] = 0xFF;
  z_stream z{};
  EXPECT_EQ(inflateInit2(&z, 15 + 16), Z_OK);
  z.next_in = const_cast<Bytef*>(compressed.data() + 40);
  z.avail_in = static_cast<uInt>(ccr_size - 32);
  z.next_out = out.data() + 8;
  z.avail_out = static_cast<uInt>(usize);
  EXPECT_EQ(inflate(&z, Z_FINISH), Z_STREAM_END);
  inflateEnd(&z);
  return out;
}

/// Position of `pattern` in `bytes` (the first), or npos.
std::size_t find(const Bytes& bytes, const Bytes& pattern) {
  const auto it = std::search(bytes.begin(), bytes.end(), pattern.begin(), pattern.end());
  return it == bytes.end() ? std::string::npos : static_cast<std::size_t>(it - bytes.begin());
}

/// The InputError message of reading `path` as a record ("" if it reads).
std::string read_error(const std::string& path) {
  try {
    mic::read_record(path);
  } catch (const mic::InputError& e) {
    return e.what();
  }
  return "";
}

const std::string kLemiCdf = "cdf/LEMI036_1_0002_0002_2025-05-14.cdf";
const std::string kFgeCdf = "cdf/FGE_S0252_0002_0002_2025-05-14.cdf";

}  // namespace

TEST(CdfReader, WicPairEqualsTheIaga2002ConversionWithinItsRounding) {
  const std::pair<std::string, std::string> pairs[] = {{kLemiCdf, "wic20250514_lemi036.sec.gz"},
                                                       {kFgeCdf, "wic20250514_fge.sec.gz"}};
  for (const auto& [cdf_name, iaga_name] : pairs) {
    SCOPED_TRACE(cdf_name);
    const std::string path = test_data(cdf_name);
    EXPECT_EQ(mic::detect_record_format(path), mic::RecordFormat::kCdf);
    const mic::VectorRecord cdf = mic::read_record(path);
    const mic::VectorRecord iaga = mic::read_iaga2002(package_data(iaga_name));
    ASSERT_EQ(cdf.size(), 86400u);
    ASSERT_EQ(cdf.size(), iaga.size());
    EXPECT_EQ(cdf.components, iaga.components);  // H, E, Z from DataComponents
    EXPECT_EQ(cdf.station, "WIC");
    EXPECT_EQ(cdf.header.at("cdf_layout"), "MagPy CDF");
    std::size_t compared = 0;
    double largest = 0.0;
    for (std::size_t i = 0; i < cdf.size(); ++i) {
      ASSERT_EQ(cdf.time_s[i], iaga.time_s[i]) << "sample " << i;
      for (int c = 0; c < 3; ++c) {
        const double a = cdf.values_nT(static_cast<Eigen::Index>(i), c), b = iaga.values_nT(static_cast<Eigen::Index>(i), c);
        ASSERT_EQ(std::isnan(a), std::isnan(b)) << "sample " << i;
        if (std::isnan(a)) continue;
        largest = std::max(largest, std::abs(a - b));
        ++compared;
      }
    }
    EXPECT_EQ(compared, 3u * 86400u);
    EXPECT_LE(largest, 0.005 + 1e-9);  // IAGA-2002 holds the values rounded to 0.01 nT
  }
}

TEST(CdfReader, MagPyTemperaturesAndCompensationAttributes) {
  const mic::VectorRecord lemi = mic::read_record(test_data(kLemiCdf));
  ASSERT_EQ(lemi.auxiliary.size(), 2u);
  EXPECT_EQ(lemi.auxiliary[0].name, "t1");
  EXPECT_EQ(lemi.auxiliary[0].description, "T_sensor");
  EXPECT_EQ(lemi.auxiliary[1].name, "t2");
  EXPECT_EQ(lemi.auxiliary[1].description, "T_elec");
  for (const mic::AuxiliaryChannel& t : lemi.auxiliary) {
    EXPECT_EQ(t.unit, "degC");
    ASSERT_EQ(t.values.size(), lemi.size());
    const auto [low, high] = std::minmax_element(t.values.begin(), t.values.end());
    EXPECT_GT(*low, -40.0);  // a borehole sensor and its electronics box: plausible degC, all present
    EXPECT_LT(*high, 60.0);
  }
  EXPECT_NE(lemi.auxiliary[0].values, lemi.auxiliary[1].values);
  EXPECT_EQ(lemi.header.at("DataCompensationX"), "-20.7425");
  EXPECT_EQ(lemi.header.at("DataCompensationZ"), "-43.865");
  EXPECT_EQ(lemi.header.at("DataComponents"), "HEZ");
  EXPECT_TRUE(mic::read_record(test_data(kFgeCdf)).auxiliary.empty());
}

TEST(CdfReader, TruncatedAndCorruptFilesNameTheFileAndThePart) {
  const std::string dir = mic::test::make_temp_dir("cdf_errors");
  const Bytes compressed = file_bytes(test_data(kLemiCdf));
  ASSERT_GT(compressed.size(), 100000u);
  auto error_of = [&](const std::string& name, const Bytes& bytes) {
    const std::string path = dir + "/" + name;
    write_cdf_file(path, bytes);
    const std::string message = read_error(path);
    EXPECT_TRUE(contains(message, path)) << message;
    return message;
  };
  // Truncated: inside the CCR header, inside the gzip stream.
  EXPECT_TRUE(contains(error_of("cut20.cdf", Bytes(compressed.begin(), compressed.begin() + 20)), "CCR"));
  const std::string cut = error_of("cut.cdf", Bytes(compressed.begin(), compressed.begin() + 100000));
  EXPECT_TRUE(contains(cut, "compressed-file record (CCR)")) << cut;
  // A damaged gzip stream.
  Bytes damaged = compressed;
  for (std::size_t i = 50000; i < 50100; ++i) damaged[i] ^= 0x5A;
  EXPECT_TRUE(contains(error_of("damaged.cdf", damaged), "GZIP")) << error_of("damaged.cdf", damaged);
  // Unknown whole-file compression: the CPR's type (RLE = 1).
  Bytes rle = compressed;
  const std::size_t cpr = static_cast<std::size_t>(be64(compressed, 20));
  ASSERT_EQ(rle[cpr + 15], 5);
  rle[cpr + 15] = 1;
  EXPECT_TRUE(contains(error_of("rle.cdf", rle), "compression type 1 is not supported")) << error_of("rle.cdf", rle);

  const Bytes plain = uncompressed_cdf(compressed);
  ASSERT_EQ(mic::read_record((write_cdf_file(dir + "/plain.cdf", plain), dir + "/plain.cdf")).size(), 86400u);
  // Truncated uncompressed file.
  const std::string half = error_of("half.cdf", Bytes(plain.begin(), plain.begin() + static_cast<long>(plain.size() / 2)));
  EXPECT_TRUE(contains(half, "CDF ")) << half;
  // A variable compressed with Huffman (type 2): its CPR (size 28, type 11, GZIP).
  Bytes huffman = plain;
  const std::size_t var_cpr = find(plain, {0, 0, 0, 0, 0, 0, 0, 0x1c, 0, 0, 0, 0x0b, 0, 0, 0, 5});
  ASSERT_NE(var_cpr, std::string::npos);
  huffman[var_cpr + 15] = 2;
  const std::string huffman_error = error_of("huffman.cdf", huffman);
  EXPECT_TRUE(contains(huffman_error, "compression type 2 is not supported")) << huffman_error;
  // A missing variable: x renamed to q in its zVDR (256-byte name field).
  Bytes pattern(256, 0);
  pattern[0] = 'x';
  Bytes no_x = plain;
  const std::size_t x_name = find(plain, pattern);
  ASSERT_NE(x_name, std::string::npos);
  no_x[x_name] = 'q';
  const std::string missing = error_of("no_x.cdf", no_x);
  EXPECT_TRUE(contains(missing, "variable x missing")) << missing;
  EXPECT_TRUE(contains(missing, "variables: Epoch, q, y, z, t1, t2, var2")) << missing;
  // Another flavour: neither MagPy nor ImagCDF (x, y, z renamed, DataFormat renamed).
  Bytes other = no_x;
  for (const char v : {'y', 'z'}) {
    pattern[0] = static_cast<std::uint8_t>(v);
    other[find(other, pattern)] = 'q';
  }
  const std::size_t format = find(other, {'D', 'a', 't', 'a', 'F', 'o', 'r', 'm', 'a', 't', 0});
  ASSERT_NE(format, std::string::npos);
  other[format] = 'd';
  const std::string flavour = error_of("other.cdf", other);
  EXPECT_TRUE(contains(flavour, "neither MagPy CDF")) << flavour;
  // CDF before 2.6 (magic 0x0000FFFF twice) and a VAX encoding (CDR byte 36).
  Bytes old = plain;
  old[0] = old[1] = 0x00, old[2] = old[3] = 0xFF;
  EXPECT_TRUE(contains(error_of("old.cdf", old), "is not CDF 2.6 (0xCDF26002) or 3.x"));
  Bytes vax = plain;
  ASSERT_EQ(vax[39], 6);  // IBMPC
  vax[39] = 3;
  EXPECT_TRUE(contains(error_of("vax.cdf", vax), "VAX floating-point encoding 3 is not supported"));
  // Not a CDF at all is still read as text: CSV's message, not a CDF one.
  EXPECT_FALSE(contains(error_of("text.cdf", Bytes{'h', 'e', 'l', 'l', 'o', '\n'}), "CDF"));
}

TEST(CdfReader, RandomDamageGivesAnInputErrorOrARecordNeverACrash) {
  const Bytes plain = uncompressed_cdf(file_bytes(test_data(kFgeCdf)));
  std::mt19937 random(16);
  std::uniform_int_distribution<std::size_t> structure(0, 12000), anywhere(0, plain.size() - 1);
  std::uniform_int_distribution<int> byte(0, 255);
  std::size_t errors = 0, records = 0;
  for (int trial = 0; trial < 120; ++trial) {
    Bytes b = plain;
    for (int k = 0; k < 4; ++k) b[trial % 4 == 3 ? anywhere(random) : structure(random)] = static_cast<std::uint8_t>(byte(random));
    try {
      const mic::VectorRecord r = mic::cdf_to_vector_record(mic::CdfFile::parse(b, "damaged.cdf"));
      EXPECT_LE(r.size(), 86400u);
      ++records;
    } catch (const mic::InputError& e) {
      EXPECT_TRUE(contains(e.what(), "damaged.cdf: ")) << e.what();
      ++errors;
    }
  }
  EXPECT_EQ(errors + records, 120u);
  EXPECT_GT(errors, 0u);
}
