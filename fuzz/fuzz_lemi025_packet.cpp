// libFuzzer target: one LEMI-025 packet (lemi025_packet.hpp).
// Input: the packet's 153 bytes (shorter inputs are padded with zeros, longer ones cut).
// Checks, for each checksum mode and plausibility setting:
//  - decode_lemi025_packet returns a packet or throws InputError, exactly as
//    check_lemi025_frame + lemi025_checksum_ok predict;
//  - a decoded packet has finite times and each reading plausible or NaN in all three components
//    (exactly the readings check_lemi025_structure would refuse); with every reading plausible,
//    encode_lemi025_packet (kNone: byte 152 kept) gives back the same 153 bytes (lossless codec);
//  - decode_lemi025_packet_unchecked never throws.
#include "fuzz_common.hpp"

#include "magnetometer_insitu_calibration/formats/lemi025_packet.hpp"

#include <algorithm>
#include <array>

using namespace magnetometer_insitu_calibration;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (!mic_fuzz::within_bounds(data, size, false)) return -1;
  std::array<std::uint8_t, kLemi025PacketSize> bytes{};
  std::copy(data, data + std::min(size, bytes.size()), bytes.begin());

  try {
    (void)decode_lemi025_packet_unchecked(bytes.data());
  } catch (...) {
    mic_fuzz::unexpected_exception(__FILE__, __LINE__);
  }

  for (const ChecksumMode mode : {ChecksumMode::kNone, ChecksumMode::kSum8, ChecksumMode::kXor8}) {
    for (const bool status : {true, false}) {
      Lemi025Plausibility limits;
      limits.check_status_bytes = status;
      const bool expect_ok = check_lemi025_frame(bytes.data(), mode, limits) == Lemi025Problem::kOk &&
                             lemi025_checksum_ok(bytes.data(), mode);
      const bool all_plausible = check_lemi025_structure(bytes.data(), limits) != Lemi025Problem::kBadReadings;
      try {
        const Lemi025Packet p = decode_lemi025_packet(bytes.data(), mode, limits);
        FUZZ_CHECK(expect_ok, "decoded a packet that check_lemi025_frame/checksum refuse");
        FUZZ_CHECK(std::isfinite(p.gps_time_s), "accepted packet without a finite GPS time");
        for (int k = 0; k < kLemi025ReadingsPerPacket; ++k) {
          FUZZ_CHECK(std::isfinite(p.sample_time_s(k)), "sample time not finite");
          const auto row = p.variation_nT.row(k);
          FUZZ_CHECK(row.array().isNaN().all() ||
                         lemi_reading_plausible(row(0), row(1), row(2), limits),
                     "implausible reading accepted as a number");
        }
        FUZZ_CHECK(p.variation_nT.allFinite() == all_plausible, "NaN readings differ from the plausibility rule");
        if (!all_plausible) continue;  // NaN readings: the bytes are not re-encodable
        FUZZ_CHECK(p.full_field_nT().allFinite(), "full field not finite");
        const auto again = encode_lemi025_packet(p, ChecksumMode::kNone);
        FUZZ_CHECK(again == bytes, "encode(decode(bytes)) != bytes");
        if (mode != ChecksumMode::kNone) {
          FUZZ_CHECK(encode_lemi025_packet(p, mode) == bytes, "checksum re-encoding differs");
        }
      } catch (const InputError&) {
        FUZZ_CHECK(!expect_ok, "InputError for a packet that passes the checks");
      } catch (...) {
        mic_fuzz::unexpected_exception(__FILE__, __LINE__);
      }
    }
  }
  return 0;
}
