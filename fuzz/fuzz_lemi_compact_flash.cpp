// libFuzzer target: LEMI-025 compact-flash images (lemi_archive.hpp: decode_lemi_flash_block,
// read_lemi_flash_blocks, read_lemi_compact_flash, lemi_flash_block_second).
// Input: the card image's bytes (written to an in-memory file); its first 512 bytes are also
// decoded directly as one block.
// Checks: a value or InputError; blocks lie in the file at increasing, non-overlapping offsets;
// the VectorRecord has finite, strictly increasing times. The card has no checksum and the
// reader documents no plausibility check, so a reading may be any float (even +-inf, which the
// record then carries): values are not range-checked here.
#include "fuzz_common.hpp"

#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"

using namespace magnetometer_insitu_calibration;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (!mic_fuzz::within_bounds(data, size, false)) return -1;
  if (size >= kLemiFlashBlockSize) {
    try {
      const LemiFlashBlock block = decode_lemi_flash_block(data);
      FUZZ_CHECK(std::isfinite(block.time_s), "block time not finite");
      for (int s = 0; s < 3; ++s) (void)lemi_flash_block_second(block, s);
    } catch (const InputError&) {
    } catch (...) {
      mic_fuzz::unexpected_exception(__FILE__, __LINE__);
    }
  }
  mic_fuzz::InputFile& file = mic_fuzz::input_file();
  file.set(data, size);
  std::vector<std::string> warnings;
  try {
    const std::vector<LemiFlashBlock> blocks = read_lemi_flash_blocks(file.path(), &warnings);
    FUZZ_CHECK(!blocks.empty(), "no blocks but no InputError");
    for (std::size_t i = 0; i < blocks.size(); ++i) {
      FUZZ_CHECK(blocks[i].offset + kLemiFlashBlockSize <= size, "block beyond the end of the file");
      if (i > 0)
        FUZZ_CHECK(blocks[i].offset >= blocks[i - 1].offset + kLemiFlashBlockSize, "blocks overlap");
      FUZZ_CHECK(std::isfinite(blocks[i].time_s), "block time not finite");
    }
  } catch (const InputError&) {
  } catch (...) {
    mic_fuzz::unexpected_exception(__FILE__, __LINE__);
  }
  warnings.clear();
  try {
    LemiReadOptions options;
    options.field = size % 2 ? LemiFieldMode::kVariation : LemiFieldMode::kFullField;
    const VectorRecord record = read_lemi_compact_flash(file.path(), options, &warnings);
    // Times only (see above): values may be +-inf from a damaged card.
    mic_fuzz::check_record_times(record);
  } catch (const InputError&) {
  } catch (...) {
    mic_fuzz::unexpected_exception(__FILE__, __LINE__);
  }
  return 0;
}
