// Benchmark (a program, not a test): reading one day of one-second WIC data (86400 samples) as
// MagPy CDF (whole-file and per-variable GZIP, as published), as ImagCDF written by the package
// (plain, and GZIP per variable), and as IAGA-2002 (the shipped .sec.gz and its plain text).
// MB/s counts the bytes of the file as stored. docs/formats_cdf.md quotes its output:
//   build/devel/lib/magnetometer_insitu_calibration/bench_cdf_read --benchmark_repetitions=3
// Run from the package root (it reads test/data/cdf and data/ and writes to /tmp).
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/formats/imagcdf_writer.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "magnetometer_insitu_calibration/formats/text_lines.hpp"

#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <fstream>

namespace mic = magnetometer_insitu_calibration;

namespace {

const std::string kMagPy = "test/data/cdf/LEMI036_1_0002_0002_2025-05-14.cdf";
const std::string kIagaGz = "data/wic20250514_lemi036.sec.gz";

/// The benchmark inputs written once: ImagCDF plain and gzip, IAGA-2002 plain.
const std::string& prepared(const std::string& which) {
  static std::map<std::string, std::string> files;
  if (files.empty()) {
    const std::string dir = std::filesystem::temp_directory_path() / "mic_bench_cdf";
    std::filesystem::create_directories(dir);
    const mic::VectorRecord lemi = mic::read_record(kMagPy);
    mic::ImagCdfWriteOptions o;
    mic::write_imagcdf(dir + "/imagcdf.cdf", lemi, o);
    o.gzip = true;
    mic::write_imagcdf(dir + "/imagcdf_gzip.cdf", lemi, o);
    mic::TextLineReader reader(kIagaGz);
    std::ofstream plain(dir + "/lemi.sec", std::ios::binary);
    std::string line;
    while (reader.next(line)) plain << line << "\r\n";
    files = {{"imagcdf", dir + "/imagcdf.cdf"}, {"imagcdf_gzip", dir + "/imagcdf_gzip.cdf"}, {"iaga", dir + "/lemi.sec"}};
  }
  return files.at(which);
}

void read_file(benchmark::State& state, const std::string& path) {
  const auto bytes = static_cast<std::int64_t>(std::filesystem::file_size(path));
  std::size_t samples = 0;
  for (auto _ : state) {
    const mic::VectorRecord r = mic::read_record(path);
    samples = r.size();
    benchmark::DoNotOptimize(r.values_nT(0, 0));
  }
  state.SetBytesProcessed(state.iterations() * bytes);
  state.counters["file_MB"] = static_cast<double>(bytes) / 1e6;
  state.counters["samples"] = static_cast<double>(samples);
}

void magpy_cdf(benchmark::State& state) { read_file(state, kMagPy); }
void imagcdf_plain(benchmark::State& state) { read_file(state, prepared("imagcdf")); }
void imagcdf_gzip(benchmark::State& state) { read_file(state, prepared("imagcdf_gzip")); }
void iaga2002_gz(benchmark::State& state) { read_file(state, kIagaGz); }
void iaga2002_plain(benchmark::State& state) { read_file(state, prepared("iaga")); }

}  // namespace

BENCHMARK(magpy_cdf)->Unit(benchmark::kMillisecond);
BENCHMARK(imagcdf_plain)->Unit(benchmark::kMillisecond);
BENCHMARK(imagcdf_gzip)->Unit(benchmark::kMillisecond);
BENCHMARK(iaga2002_gz)->Unit(benchmark::kMillisecond);
BENCHMARK(iaga2002_plain)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
