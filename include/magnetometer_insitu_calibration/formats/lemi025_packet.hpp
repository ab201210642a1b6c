// One LEMI-025 (or LEMI-036) data packet as sent once per second over RS-232 (vendor protocol
// v6, "Table 2. Data stream from LEMI-025 to PC"): decoding, encoding and checksums.
//
// Byte layout (153 bytes, multi-byte numbers little-endian):
//   0-3     "L025" (a LEMI-036 sends "L036"; both are accepted, Lemi025Packet::model says which)
//   4       station number, uint8 (1-255, plain binary)
//   5-10    GPS time, BCD: yy mm dd hh mm ss (UTC; year = 2000 + yy)
//   11-12   sensor temperature x100, int16, deg C
//   13-14   electronics temperature x100, int16, deg C
//   15-20   DAC counts X, Y, Z of the bias sub-unit, int16
//   21-26   bias field X, Y, Z x400 in uT, int16 (i.e. steps of 2.5 nT)
//   27      reserved (0x00)
//   28-147  ten readings of X, Y, Z, float32, uT: variations relative to the bias field
//   148     mode, uint8: 1 flash, 2 PC, 3 flash + PC
//   149     free flash memory, uint8, %
//   150     supply voltage x10, uint8, V
//   151     GPS status, char: 'A' active, 'P' passive, 'O' no antenna, 'S' short circuit
//   152     checksum (algorithm not published: see ChecksumMode)
//
// Timing: the ten readings are assigned by the instrument to the GPS second stamped in bytes
// 5-10; the vendor note says the PC must shift them by -0.3 s. Reading k (0..9) was therefore
// taken at  t_gps - 0.3 s + 0.1 s * k  (Lemi025Packet::sample_time_s).
//
// Frame: X, Y, Z are the instrument's own sensor axes, in the order sent.
#pragma once

#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>

namespace magnetometer_insitu_calibration {

constexpr std::size_t kLemi025PacketSize = 153;        ///< bytes per packet
constexpr int kLemi025ReadingsPerPacket = 10;          ///< readings per packet (10 Hz)
constexpr double kLemi025SamplePeriod_s = 0.1;         ///< s between readings
constexpr double kLemi025TimeShift_s = -0.3;           ///< vendor time-scale correction, s
constexpr double kLemi025BiasStep_nT = 2.5;            ///< one count of the bias field bytes, nT

/// The packet's checksum byte (152). The vendor does not publish the algorithm, so the parser
/// can ignore it (kNone) or check one of the two usual candidates over bytes 0..151:
/// kSum8 = sum of the bytes modulo 256, kXor8 = xor of the bytes.
enum class ChecksumMode { kNone, kSum8, kXor8 };

/// Which instrument sent the packet, from its 4-byte tag.
enum class LemiModel { kLemi025, kLemi036 };

/// "LEMI-025" or "LEMI-036".
std::string lemi_model_name(LemiModel model);
/// "none", "sum8" or "xor8".
std::string checksum_mode_name(ChecksumMode mode);
/// Parses "none", "sum8", "xor8" (as printed by checksum_mode_name); nullopt otherwise.
std::optional<ChecksumMode> parse_checksum_mode(const std::string& text);

/// Readings of one packet: row k = reading k (0..9), columns X, Y, Z, nT.
using Lemi025Readings = Eigen::Matrix<double, kLemi025ReadingsPerPacket, 3>;

/// A decoded packet in SI-friendly units.
struct Lemi025Packet {
  LemiModel model = LemiModel::kLemi025;  ///< from the tag "L025" / "L036"
  std::uint8_t station = 0;               ///< station number (byte 4)
  double gps_time_s = 0.0;                ///< the packet's GPS second (bytes 5-10), UNIX s, UTC
  double sensor_temperature_C = 0.0;      ///< deg C (resolution 0.01)
  double electronics_temperature_C = 0.0; ///< deg C (resolution 0.01)
  std::array<std::int16_t, 3> dac_counts{{0, 0, 0}};  ///< bias DAC counts X, Y, Z
  Eigen::Vector3d bias_nT = Eigen::Vector3d::Zero();  ///< bias field X, Y, Z, nT (2.5 nT steps)
  std::uint8_t reserved = 0;                          ///< byte 27
  Lemi025Readings variation_nT = Lemi025Readings::Zero();  ///< X, Y, Z relative to the bias, nT
  std::uint8_t mode = 2;                  ///< 1 flash, 2 PC, 3 flash + PC
  std::uint8_t flash_free_percent = 0;    ///< free flash memory, %
  double supply_V = 0.0;                  ///< supply voltage, V (resolution 0.1)
  char gps_status = 'A';                  ///< 'A' active, 'P' passive, 'O' no antenna, 'S' short
  std::uint8_t checksum = 0;              ///< byte 152 as received (written as is by kNone)

  /// Time of reading k (0..9): gps_time_s - 0.3 + 0.1 k, UNIX s, UTC.
  double sample_time_s(int k) const;
  /// Full field of every reading: bias + variation, nT.
  Lemi025Readings full_field_nT() const;
};

/// Why a 153-byte candidate is not a packet (kOk if it is one).
enum class Lemi025Problem {
  kOk,
  kBadTag,          ///< bytes 0-3 are neither "L025" nor "L036"
  kBadTime,         ///< bytes 5-10 are not BCD or not a valid date/time
  kBadReadings,     ///< a reading is not finite or outside the plausible range
  kBadStatusBytes,  ///< mode, flash-free or GPS-status byte outside its documented values
  kBadChecksum,     ///< checksum byte differs from the selected algorithm
};
std::string lemi025_problem_text(Lemi025Problem problem);

/// Plausibility limits used to tell a real packet from a misaligned or damaged one.
struct Lemi025Plausibility {
  /// Largest accepted |variation| of one component, nT. The LEMI-025 range is +-68000 nT of
  /// full field and variations are normally a few hundred nT, so 100000 nT rejects garbage
  /// floats (1e30, denormals are accepted: they are harmless) without rejecting real data.
  double max_abs_variation_nT = 100000.0;
  /// Check bytes 148-151 against the vendor table: mode in 1..3, flash free <= 100 %,
  /// GPS status one of A P O S. A packet shifted by dropped bytes almost never passes.
  bool check_status_bytes = true;
};

/// The one plausibility rule of a LEMI reading, shared by the packet parser, the driver and the
/// compact-flash reader: X, Y, Z variations (nT, relative to the bias field) all finite and
/// |component| <= limits.max_abs_variation_nT.
bool lemi_reading_plausible(double x_nT, double y_nT, double z_nT,
                            const Lemi025Plausibility& limits = {});

/// Sets every implausible reading (row: X, Y, Z variation, nT) of `variation_nT` to NaN in all
/// three components (lemi_reading_plausible) and returns how many readings it set.
template <int Rows>
int lemi_mark_implausible_readings(Eigen::Matrix<double, Rows, 3>& variation_nT,
                                   const Lemi025Plausibility& limits = {});

/// Structure check of 153 bytes (tag, BCD date/time, EVERY reading plausible, status bytes), no
/// checksum. Strict: used where an implausible reading must reject the whole packet (record-format
/// detection, resynchronising inside a LemiBin file).
Lemi025Problem check_lemi025_structure(const std::uint8_t* bytes,
                                       const Lemi025Plausibility& limits = {});

/// Frame check of 153 bytes, the rule that finds packet boundaries in a stream: tag, BCD
/// date/time and (limits.check_status_bytes) the status bytes, which a packet shortened or
/// lengthened by lost/inserted bytes almost never passes. Readings do not decide the frame, so
/// one implausible reading does not make an intact packet a "non-packet" -- EXCEPT when
/// `checksum` is kNone and limits.check_status_bytes is false: then nothing else checks the tail
/// of the packet and every reading must be plausible (as check_lemi025_structure).
/// Never returns kBadChecksum (see lemi025_checksum_ok).
Lemi025Problem check_lemi025_frame(const std::uint8_t* bytes, ChecksumMode checksum,
                                   const Lemi025Plausibility& limits = {});

/// The checksum byte that `mode` predicts for bytes 0..151 (0 for kNone).
std::uint8_t lemi025_checksum(const std::uint8_t* bytes, ChecksumMode mode);
/// True if byte 152 matches `mode` (always true for kNone).
bool lemi025_checksum_ok(const std::uint8_t* bytes, ChecksumMode mode);

/// Decodes 153 bytes without any check (the caller checked them). BCD bytes that are not
/// valid decimal give a gps_time_s of NaN.
Lemi025Packet decode_lemi025_packet_unchecked(const std::uint8_t* bytes);

/// Decodes 153 bytes after the frame check (check_lemi025_frame) and the checksum check of
/// `mode`; implausible readings become NaN (lemi_mark_implausible_readings), as the stream parser
/// does. Throws InputError("LEMI-025 packet", <problem>) if the frame or checksum check fails.
Lemi025Packet decode_lemi025_packet(const std::uint8_t* bytes,
                                    ChecksumMode mode = ChecksumMode::kNone,
                                    const Lemi025Plausibility& limits = {});

/// Encodes a packet (for simulators and tests). Temperatures are rounded to 0.01 deg C, the
/// bias to 2.5 nT, the supply to 0.1 V, readings to float32 uT; the time is rounded to the
/// second. Byte 152 is the checksum of `mode`, or packet.checksum for kNone.
/// Throws InputError if a value does not fit its field (year outside 2000..2099, ...).
std::array<std::uint8_t, kLemi025PacketSize> encode_lemi025_packet(const Lemi025Packet& packet,
                                                                   ChecksumMode mode);

// ---- Helpers shared by the LEMI readers (BCD and UTC calendar) --------------------------------

/// Decodes one BCD byte (0x00..0x99); nullopt if a nibble is above 9.
std::optional<int> lemi_decode_bcd(std::uint8_t byte);
/// Encodes 0..99 as one BCD byte.
std::uint8_t lemi_encode_bcd(int value);
/// UNIX seconds of a UTC calendar time (proleptic Gregorian, no leap seconds); NaN if a field
/// is out of range (month 1-12, day 1..days in month, hour 0-23, minute 0-59, second 0-59).
double lemi_utc_to_unix_s(int year, int month, int day, int hour, int minute, double second);
/// Inverse of lemi_utc_to_unix_s for whole seconds: {year, month, day, hour, minute, second}.
std::array<int, 6> lemi_unix_to_utc(std::int64_t unix_s);
/// Decodes six BCD bytes yy mm dd hh mm ss (year 2000 + yy) to UNIX seconds; NaN if invalid.
double lemi_decode_bcd_time(const std::uint8_t* six_bytes);

// ---- Template definitions ----------------------------------------------------------------------

template <int Rows>
int lemi_mark_implausible_readings(Eigen::Matrix<double, Rows, 3>& variation_nT,
                                   const Lemi025Plausibility& limits) {
  int marked = 0;
  for (Eigen::Index k = 0; k < variation_nT.rows(); ++k) {
    if (lemi_reading_plausible(variation_nT(k, 0), variation_nT(k, 1), variation_nT(k, 2), limits))
      continue;
    variation_nT.row(k).setConstant(std::numeric_limits<double>::quiet_NaN());
    ++marked;
  }
  return marked;
}

}  // namespace magnetometer_insitu_calibration
