// libFuzzer target: LemiBin files (lemi_archive.hpp: read_lemi_bin_file, read_lemi_bin).
// Input: the file's bytes (written to an in-memory file). The checksum mode tried comes from the
// input size (size % 3), so the corpus exercises all three without a config byte.
// Checks: a value or InputError; records lie in the file at increasing, non-overlapping offsets
// and pass the same frame check as a stream packet (check_lemi025_frame + checksum); every decoded
// reading is NaN in x, y and z or plausible; the VectorRecord has finite, strictly increasing
// times and plausible values (|bias| + |variation| <= 81920 + 100000 nT) or NaN.
#include "fuzz_common.hpp"

#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"

using namespace magnetometer_insitu_calibration;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (!mic_fuzz::within_bounds(data, size, false)) return -1;
  mic_fuzz::InputFile& file = mic_fuzz::input_file();
  file.set(data, size);
  LemiReadOptions options;
  options.checksum = mic_fuzz::checksum_from_size(size);
  std::vector<std::string> warnings;
  try {
    const LemiBinFile bin = read_lemi_bin_file(file.path(), options, &warnings);
    FUZZ_CHECK(!bin.records.empty(), "no records but no InputError");
    for (std::size_t i = 0; i < bin.records.size(); ++i) {
      const std::uint64_t off = bin.records[i].offset;
      FUZZ_CHECK(off + kLemiBinRecordSize <= size, "record beyond the end of the file");
      if (i > 0) FUZZ_CHECK(off >= bin.records[i - 1].offset + kLemiBinRecordSize, "records overlap");
      FUZZ_CHECK(check_lemi025_frame(data + off, options.checksum, options.plausibility) == Lemi025Problem::kOk &&
                     lemi025_checksum_ok(data + off, options.checksum),
                 "record at " + std::to_string(off) + " fails the packet checks");
      const auto& v = bin.records[i].packet.variation_nT;
      for (Eigen::Index k = 0; k < v.rows(); ++k) {
        FUZZ_CHECK(v.row(k).array().isNaN().all() ||
                       lemi_reading_plausible(v(k, 0), v(k, 1), v(k, 2), options.plausibility),
                   "record at " + std::to_string(off) + ": reading " + std::to_string(k) +
                       " neither NaN nor plausible");
      }
    }
  } catch (const InputError&) {
  } catch (...) {
    mic_fuzz::unexpected_exception(__FILE__, __LINE__);
  }
  warnings.clear();
  try {
    options.field = size % 2 ? LemiFieldMode::kVariation : LemiFieldMode::kFullField;
    const VectorRecord record = read_lemi_bin(file.path(), options, &warnings);
    mic_fuzz::check_record(record, 181920.0);
  } catch (const InputError&) {
  } catch (...) {
    mic_fuzz::unexpected_exception(__FILE__, __LINE__);
  }
  return 0;
}
