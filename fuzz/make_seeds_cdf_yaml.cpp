// make_seeds, the cdf and calibration_yaml seeds (the rest and main: make_seeds.cpp): small CDF
// files (ImagCDF and MagPy CDF layouts, both encodings, GZIP per variable and per file, CDF 3.9
// and 2.7) made from the first seconds of the WIC LEMI-036 MagPy CDF in test/data/cdf, the first
// 16 KiB of that file (compressed and inflated), and a calibration YAML written by
// calibration_to_yaml.
#include "make_seeds.hpp"

#include "magnetometer_insitu_calibration/formats/cdf_epoch.hpp"
#include "magnetometer_insitu_calibration/formats/cdf_records.hpp"
#include "magnetometer_insitu_calibration/formats/cdf_writer.hpp"
#include "magnetometer_insitu_calibration/formats/imagcdf_writer.hpp"
#ifdef MIC_FUZZ_WITH_YAML
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"
#endif

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

using namespace magnetometer_insitu_calibration;

namespace make_seeds {
namespace {

/// The CDF seeds' sample: the first 12 records of the real file, no header, one NaN.
VectorRecord cdf_sample(const std::string& real) {
  VectorRecord r = read_cdf_record(real);
  const std::size_t n = 12;  // seeds under the 16 KiB -max_len of run_fuzz_short.sh
  r.header.clear();
  r.time_s.resize(n);
  r.values_nT.conservativeResize(static_cast<Eigen::Index>(n), 3);
  r.values_nT(3, 1) = std::nan("");
  for (AuxiliaryChannel& a : r.auxiliary) a.values.resize(n);
  return r;
}

/// cdf: ImagCDF, little and big endian, and with gzipped variables.
void write_imagcdf_seeds(const VectorRecord& r) {
  const std::string tmp = g_out + "/cdf_seed.tmp";
  auto imagcdf = [&](bool big, bool gzip_values) {
    ImagCdfWriteOptions o;
    o.big_endian = big;
    o.gzip = gzip_values;
    o.comments = {"seed"};
    o.publication_date_s = 1747267200.0;
    write_imagcdf(tmp, r, o);
    const Bytes b = read_bytes(tmp);
    std::remove(tmp.c_str());
    return b;
  };
  write("cdf", "imagcdf_little.cdf", imagcdf(false, false));
  write("cdf", "imagcdf_big.cdf", imagcdf(true, false));
  write("cdf", "imagcdf_gzip_variables.cdf", imagcdf(false, true));
}

/// cdf: MagPy CDF layouts, gzipped and big-endian plain (the first also for record_file), and
/// CDF 2.7 (4-byte offsets, 64-character names) with CDF_EPOCH times, compressed and plain.
void write_magpy_seeds(const VectorRecord& r) {
  const std::size_t n = r.time_s.size();
  CdfWriteContent magpy;
  magpy.gzip_file = magpy.gzip_variables = true;
  magpy.global = {{"DataFormat", {CdfWriteEntry::of_text("MagPyCDF1.2")}},
                  {"DataComponents", {CdfWriteEntry::of_text("HEZ")}},
                  {"ColumnContents", {CdfWriteEntry::of_text("X,Y,Z,,T_sensor,T_elec")}}};
  CdfWriteVariable epoch;
  epoch.name = "Epoch";
  epoch.data_type = kCdfTimeTt2000;
  for (double t : r.time_s) epoch.times.push_back(unix_to_tt2000(t));
  magpy.variables.push_back(epoch);
  for (int c = 0; c < 3; ++c) {
    CdfWriteVariable v;
    v.name = std::string(1, "xyz"[c]);
    for (std::size_t i = 0; i < n; ++i) v.values.push_back(r.values_nT(static_cast<Eigen::Index>(i), c));
    v.attributes = {{"FILLVAL", CdfWriteEntry::of_number(99999.0)}, {"DEPEND_0", CdfWriteEntry::of_text("Epoch")}};
    magpy.variables.push_back(v);
  }
  CdfWriteVariable t1;
  t1.name = "t1";
  t1.values = r.auxiliary[0].values;
  magpy.variables.push_back(t1);
  const Bytes magpy_bytes = encode_cdf(magpy);
  write("cdf", "magpy_gzip.cdf", magpy_bytes);
  magpy.gzip_file = magpy.gzip_variables = false;
  magpy.big_endian = true;
  write("cdf", "magpy_big_plain.cdf", encode_cdf(magpy));
  write("record_file", "magpy.cdf", magpy_bytes);
  magpy.version = 2;
  magpy.variables[0].data_type = kCdfEpoch;
  for (double t : r.time_s) magpy.variables[0].values.push_back((t + kCdfEpochUnixOffset_s) * 1000.0);
  write("cdf", "magpy_cdf27_big_plain.cdf", encode_cdf(magpy));
  magpy.gzip_file = magpy.gzip_variables = true;
  magpy.big_endian = false;
  write("cdf", "magpy_cdf27_gzip.cdf", encode_cdf(magpy));
}

/// cdf: the real file cut at 16 KiB, compressed and inflated (its CCR: gzip stream at byte 40).
void write_cut_cdf_seeds(const std::string& real) {
  const Bytes whole = read_bytes(real);
  write("cdf", "wic_lemi_cut.cdf", Bytes(whole.begin(), whole.begin() + 16384));
  Bytes inflated(8 + (1 << 16));
  z_stream z{};
  inflateInit2(&z, 15 + 16);
  z.next_in = const_cast<Bytef*>(whole.data() + 40);
  z.avail_in = static_cast<uInt>(whole.size() - 40);
  z.next_out = inflated.data() + 8;
  z.avail_out = 1 << 16;
  inflate(&z, Z_SYNC_FLUSH);
  inflateEnd(&z);
  std::copy(whole.begin(), whole.begin() + 4, inflated.begin());
  inflated[4] = inflated[5] = 0x00, inflated[6] = inflated[7] = 0xFF;
  inflated.resize(16384);
  write("cdf", "wic_lemi_inflated_cut.cdf", inflated);
}

}  // namespace

void write_cdf_seeds(const std::string& root) {
  const std::string real = root + "/test/data/cdf/LEMI036_1_0002_0002_2025-05-14.cdf";
  const VectorRecord r = cdf_sample(real);
  write_imagcdf_seeds(r);
  write_magpy_seeds(r);
  write_cut_cdf_seeds(real);
}

#ifdef MIC_FUZZ_WITH_YAML

void write_calibration_yaml_seeds(const std::string& root) {
  MagnetometerCalibration c;
  c.test_name = "lemi036";
  c.header.stamp = ros::Time(1747192217, 250000000);
  c.header.frame_id = "reference_frame";
  c.reference_frame_id = "reference_frame";
  c.test_frame_id = "lemi036_frame";
  c.window_start = ros::Time(1747181400, 0);
  c.window_end = ros::Time(1747192199, 0);
  c.sample_period = 1.0;
  c.samples = 10800;
  c.filled_samples = 3;
  c.band_low_hz = 2e-4;
  c.band_high_hz = 0.01;
  c.harmonic_first = 3;
  c.harmonic_last = 108;
  c.gamma = 1.0;
  c.trend_column = true;
  c.matrix = {{0.9995, 0.0046, 0.0017, -0.0051, 0.9992, 2.5e-05, -0.0010, -0.0003, 0.99996}};
  for (std::size_t i = 0; i < 81; ++i) c.matrix_covariance[i] = i % 10 == 0 ? 5e-7 : 1e-9;
  c.trend_nT_per_day = {{0.1, -0.2, 0.05}};
  c.trend_ci95_nT_per_day = {{0.01, 0.02, 0.01}};
  c.scale_ratio = {{1.0004, 0.9992, 1.00004}};
  c.scale_ratio_ci95 = {{1e-4, 1e-4, 1e-4}};
  c.nonorthogonality_deg = {{0.05, -0.02, 0.01}};
  c.nonorthogonality_ci95_deg = {{0.01, 0.01, 0.01}};
  c.misalignment_deg = {{0.2, -0.1, 0.3}};
  c.misalignment_ci95_deg = {{0.02, 0.02, 0.02}};
  c.axis_deviation_deg = {{0.26, 0.3, 0.1}};
  c.axis_deviation_ci95_deg = {{0.02, 0.02, 0.02}};
  c.condition_number = 1.02;
  c.coherence = {{0.999, 0.998, std::nan("")}};
  c.residual_rms_nT = {{0.05, 0.04, std::numeric_limits<double>::infinity()}};
  c.quality = 1;
  c.quality_text = "good: \"quoted\" and \\ back-slashed\nsecond line";
  c.accepted = true;
  const std::string yaml = calibration_to_yaml(c, "/calibration_node");
  write("calibration_yaml", "calibration.yaml", yaml);
  write("calibration_yaml", "half_written.yaml", yaml.substr(0, yaml.size() / 2));
  for (const char* name : {"half_written_calibration.yaml", "malformed_calibration.yaml"})
    write("calibration_yaml", name, read_bytes(root + "/test/ros/data/" + name));
}
#endif

}  // namespace make_seeds
