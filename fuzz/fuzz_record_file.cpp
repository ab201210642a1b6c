// libFuzzer target: format detection and dispatch (record_file.hpp: detect_record_format,
// read_record with LEMI options and warnings) over any of the five formats.
// Input: the file's bytes (written to an in-memory file; gzip inputs that inflate to more than
// 1 MiB are declined). LEMI options from the input size (checksum size % 3, field size % 2).
// Checks: a value or InputError; detection is deterministic; finite, strictly increasing times
// and one row per time (values are not range-checked: a compact-flash card has no plausibility
// check, see fuzz_lemi_compact_flash.cpp).
#include "fuzz_common.hpp"

#include "magnetometer_insitu_calibration/record_file.hpp"

using namespace magnetometer_insitu_calibration;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (!mic_fuzz::within_bounds(data, size, true)) return -1;
  mic_fuzz::InputFile& file = mic_fuzz::input_file();
  file.set(data, size);
  try {
    const RecordFormat format = detect_record_format(file.path());
    FUZZ_CHECK(detect_record_format(file.path()) == format, "detection not deterministic");
    FUZZ_CHECK(record_format_name(format) != std::string("unknown"), "unknown format");
  } catch (const InputError&) {
  } catch (...) {
    mic_fuzz::unexpected_exception(__FILE__, __LINE__);
  }
  LemiReadOptions options;
  options.checksum = size % 3 == 1 ? ChecksumMode::kSum8
                     : size % 3 == 2 ? ChecksumMode::kXor8
                                     : ChecksumMode::kNone;
  options.field = size % 2 ? LemiFieldMode::kVariation : LemiFieldMode::kFullField;
  std::vector<std::string> warnings;
  try {
    const VectorRecord record = read_record(file.path(), options, &warnings);
    FUZZ_CHECK(record.values_nT.rows() == static_cast<Eigen::Index>(record.time_s.size()), "rows");
    for (std::size_t i = 0; i < record.time_s.size(); ++i) {
      FUZZ_CHECK(std::isfinite(record.time_s[i]), "time not finite");
      if (i > 0) FUZZ_CHECK(record.time_s[i] > record.time_s[i - 1], "times not increasing");
    }
  } catch (const InputError&) {
  } catch (...) {
    mic_fuzz::unexpected_exception(__FILE__, __LINE__);
  }
  return 0;
}
