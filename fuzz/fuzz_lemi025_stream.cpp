// libFuzzer target: a raw capture of the LEMI-025 serial stream read as a file
// (lemi_archive.hpp: read_lemi025_stream).
// Input: the capture's bytes (written to an in-memory file); checksum mode from size % 3.
// Checks: a value or InputError; the VectorRecord has finite, strictly increasing times and
// plausible values; the header's packet count is at most size / 153.
#include "fuzz_common.hpp"

#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"

using namespace magnetometer_insitu_calibration;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (!mic_fuzz::within_bounds(data, size, false)) return -1;
  mic_fuzz::InputFile& file = mic_fuzz::input_file();
  file.set(data, size);
  LemiReadOptions options;
  options.checksum = mic_fuzz::checksum_from_size(size);
  options.field = size % 2 ? LemiFieldMode::kVariation : LemiFieldMode::kFullField;
  std::vector<std::string> warnings;
  try {
    const VectorRecord record = read_lemi025_stream(file.path(), options, &warnings);
    mic_fuzz::check_record(record, 181920.0);
    FUZZ_CHECK(!record.empty(), "empty record but no InputError");
    const std::size_t packets = std::stoul(record.header.at("packets"));
    FUZZ_CHECK(packets >= 1 && packets <= size / kLemi025PacketSize, "packets header");
    FUZZ_CHECK(record.size() <= packets * kLemi025ReadingsPerPacket, "more samples than readings");
  } catch (const InputError&) {
  } catch (...) {
    mic_fuzz::unexpected_exception(__FILE__, __LINE__);
  }
  return 0;
}
