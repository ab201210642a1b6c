// libFuzzer target: NASA CDF files (cdf_file.hpp: CdfFile::parse, read_real, read_int64;
// cdf_records.hpp: cdf_to_vector_record, MagPy CDF and ImagCDF layouts).
// Input: the file's bytes, parsed from memory (whole-file and per-variable GZIP are inflated
// by the reader, which caps every array at 256 MiB).
// Checks: a value or InputError; every variable's values are whole records (values_per_record
// each); the VectorRecord has finite, strictly increasing times, NaN or finite values, and
// auxiliary channels of one value per time.
#include "fuzz_common.hpp"

#include "magnetometer_insitu_calibration/formats/cdf_file.hpp"
#include "magnetometer_insitu_calibration/formats/cdf_records.hpp"

using namespace magnetometer_insitu_calibration;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (!mic_fuzz::within_bounds(data, size, false)) return -1;
  try {
    const CdfFile file = CdfFile::parse(std::vector<std::uint8_t>(data, data + size), "fuzz.cdf");
    for (const CdfVariable& v : file.variables()) {
      const std::size_t per_record = v.values_per_record * static_cast<std::size_t>(v.num_elems);
      try {
        if (v.data_type == kCdfInt8 || v.data_type == kCdfTimeTt2000) {
          FUZZ_CHECK(file.read_int64(v).size() % per_record == 0, "int64 values not whole records");
        } else if (v.data_type != kCdfChar && v.data_type != kCdfUchar) {
          FUZZ_CHECK(file.read_real(v).size() % per_record == 0, "values not whole records");
        }
      } catch (const InputError&) {
      }
    }
    const VectorRecord record = cdf_to_vector_record(file);
    mic_fuzz::check_record(record);
    for (const AuxiliaryChannel& a : record.auxiliary) {
      FUZZ_CHECK(a.values.size() == record.size(), "auxiliary channel " + a.name + " not one value per time");
    }
  } catch (const InputError&) {
  } catch (...) {
    mic_fuzz::unexpected_exception(__FILE__, __LINE__);
  }
  return 0;
}
