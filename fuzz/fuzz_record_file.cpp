// libFuzzer target: format detection and dispatch (record_file.hpp: detect_record_format,
// read_record) over any of the formats it knows (IAGA-2002, CSV and, with the LEMI detection,
// LemiBin, compact flash and raw LEMI-025 streams with default options; the LEMI options and
// warnings are fuzzed by the per-format targets).
// Input: the file's bytes (written to an in-memory file; gzip inputs that inflate to more than
// 1 MiB are declined).
// Checks: a value or InputError; detection is deterministic; finite, strictly increasing times
// and one row per time (values are not range-checked: a compact-flash card has no plausibility
// check, see fuzz_lemi_compact_flash.cpp).
#include "fuzz_common.hpp"

#include "magnetometer_insitu_calibration/formats/record_file.hpp"

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
  try {
    const VectorRecord record = read_record(file.path());
    mic_fuzz::check_record_times(record);
  } catch (const InputError&) {
  } catch (...) {
    mic_fuzz::unexpected_exception(__FILE__, __LINE__);
  }
  return 0;
}
