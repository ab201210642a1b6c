// libFuzzer target: CSV records, plain or gzip (csv_record.hpp: read_csv_record).
// Input: the file's bytes (written to an in-memory file; gzip inputs that inflate to more than
// 1 MiB are declined to keep one execution short).
// Checks: a value or InputError (never std::invalid_argument or another exception); finite,
// strictly increasing times; values NaN or finite and below the 88888 nT sentinel.
#include "fuzz_common.hpp"

#include "magnetometer_insitu_calibration/formats/csv_record.hpp"

using namespace magnetometer_insitu_calibration;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return mic_fuzz::check_input_file(data, size, true,
                                    [](const std::string& path) { mic_fuzz::check_text_record(read_csv_record(path)); });
}
