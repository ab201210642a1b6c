// Readers of LEMI-025 recordings: LemiBin files (PC acquisition software), the logger's
// compact-flash card, and raw captures of the serial byte stream. All return 10 Hz records in
// nT with the vendor's -0.3 s time correction applied.
//
// ---- LemiBin ----------------------------------------------------------------------------------
// Optional text header line starting "LemiBin" and ending '\n' (e.g. MagPy/MARTAS write
// "LemiBin <sensor id> [x,y,z,t1,t2] ... <record size>\n"; the second word is kept as
// header["sensor_id"]; a last word that is a number other than 169 is refused). Then records of
// 169 bytes: the 153-byte packet (lemi025_packet.hpp) followed by the PC clock at reception:
//   153-164  six int16 LE: year - 2000, month, day, hour, minute, second
//   165-168  uint32 LE: microseconds
// A file starting directly with "L025" (no header line) is read the same way.
//
// ---- Compact flash ----------------------------------------------------------------------------
// Vendor protocol v6, "Table 1. LEMI-025 Compact Flash Data Format": 512-byte blocks, each a
// 32-byte caption and 30 readings of 16 bytes (3 s at 10 Hz).
// Caption:
//   0-3    "L025" ("L036" accepted too)
//   4      station number, BCD per the vendor table (a byte that is not BCD is kept as binary)
//   5-10   BCD yy mm dd hh mm ss, UTC, year 2000 + yy: time of reading 1
//   11-15  latitude: BCD dd, BCD mm, BCD mmmm (ten-thousandths of a minute), then 'N' or 'S'
//          (vendor example 49 47 94 45 4E = 49 deg 47.9445' N)
//   16-21  longitude: BCD dd dd (4 digits), BCD mm, BCD mmmm, then 'E' or 'W'
//          (vendor example 00 24 00 54 96 45 = 24 deg 00.5496' E)
//   22     GPS status char: A, P, O, S
//   23     reserved (0x00)
//   24     supply voltage x10, uint8
//   25-30  bias field X, Y, Z x400 uT, int16 LE
//   31     service information (kept raw)
// Reading (16 bytes): X, Y, Z variations float32 LE in uT; sensor and electronics temperature
// x100 int16 LE in deg C.
// Choices where the vendor table is silent (ours, documented and tested):
//   * reading j (0..29) of a block belongs to caption time + 0.1 s * j, and the same -0.3 s
//     correction as the serial packets is applied (the card stores the same GPS-assigned samples
//     as the serial stream; MagPy's reader notes a ~0.3 s shift "must be accounted for");
//   * a block whose 512 bytes are all 0x00 or all 0xFF is an erased block: counted, not warned
//     one by one;
//   * a block that does not start with a valid caption (tag, BCD time) is reported and the
//     reader searches forward for the next valid caption (any alignment) and goes on from it;
//   * latitude/longitude that are not BCD (no fix) are NaN.
//
// ---- Raw stream capture ----------------------------------------------------------------------
// The bytes as read from the serial port, parsed by Lemi025StreamParser.
//
// ---- Errors ------------------------------------------------------------------------------------
// A file that cannot be opened, a LemiBin header that declares another record size, or a file
// with no valid record at all throws InputError(path, ...). A damaged record is reported in the
// warnings ("<path> byte <offset>: <problem>"), the reader resynchronises on the next valid
// record and goes on: nothing good after a bad record is lost. Samples whose time is not after
// the previous sample's (a clock step backwards, a repeated packet) are dropped with a warning,
// so the record's times are strictly increasing. Gaps are left as gaps (no NaN rows).
#pragma once

#include "magnetometer_insitu_calibration/formats/lemi025_packet.hpp"
#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// Which values a reader returns.
enum class LemiFieldMode {
  kFullField,  ///< bias + variation: the field in the sensor frame, nT (default)
  kVariation,  ///< variation relative to the bias only, nT (jumps when the bias is re-set)
};

struct LemiReadOptions {
  /// Full field by default: the in-situ calibration acts on the full field vector, and a bias
  /// re-set would otherwise appear as a step in the data.
  LemiFieldMode field = LemiFieldMode::kFullField;
  /// Added to the GPS-assigned time of every reading, s (vendor: -0.3 s).
  double time_shift_s = kLemi025TimeShift_s;
  /// Checksum of LemiBin records and stream packets (the vendor algorithm is not public).
  ChecksumMode checksum = ChecksumMode::kNone;
  /// Plausibility used to accept a LemiBin record or stream packet.
  Lemi025Plausibility plausibility;
};

// ---- LemiBin ---------------------------------------------------------------------------------

constexpr std::size_t kLemiBinRecordSize = 169;  ///< bytes per LemiBin record

/// One LemiBin record: the packet and the PC clock when it arrived.
struct LemiBinRecord {
  Lemi025Packet packet;
  double pc_time_s = 0.0;     ///< PC clock, UNIX s, UTC (NaN if the fields are not a date)
  std::uint64_t offset = 0;   ///< byte offset of the record in the file
};

/// The LemiBin file's header line ("" if none) and its records.
struct LemiBinFile {
  std::string header_line;   ///< without the trailing '\n'
  std::string sensor_id;     ///< second word of the header line, if any
  std::vector<LemiBinRecord> records;
};

/// Reads every valid record; problems go to *warnings (if given). Throws InputError (above).
LemiBinFile read_lemi_bin_file(const std::string& path, const LemiReadOptions& options = {},
                               std::vector<std::string>* warnings = nullptr);

/// LemiBin as a 10 Hz VectorRecord (see LemiReadOptions for the values and times).
VectorRecord read_lemi_bin(const std::string& path, const LemiReadOptions& options = {},
                           std::vector<std::string>* warnings = nullptr);

/// Writes a LemiBin file (header line + 169-byte records), for tests and simulators.
void write_lemi_bin(const std::string& path, const std::vector<LemiBinRecord>& records,
                    const std::string& sensor_id = "LEMI025", ChecksumMode mode = ChecksumMode::kNone);

// ---- Compact flash ---------------------------------------------------------------------------

constexpr std::size_t kLemiFlashBlockSize = 512;       ///< bytes per block
constexpr std::size_t kLemiFlashCaptionSize = 32;      ///< caption bytes
constexpr int kLemiFlashReadingsPerBlock = 30;         ///< 16-byte readings per block

/// One decoded compact-flash block.
struct LemiFlashBlock {
  LemiModel model = LemiModel::kLemi025;
  int station = 0;                  ///< station number (BCD-decoded when it is BCD)
  double time_s = 0.0;              ///< caption time = time of reading 0 before the shift, UNIX s
  double latitude_deg = 0.0;        ///< + north, NaN if not BCD
  double longitude_deg = 0.0;       ///< + east, NaN if not BCD
  char gps_status = 'A';            ///< A, P, O, S
  std::uint8_t reserved = 0;        ///< caption byte 23
  double supply_V = 0.0;            ///< V
  Eigen::Vector3d bias_nT = Eigen::Vector3d::Zero();  ///< bias field X, Y, Z, nT
  std::uint8_t service = 0;         ///< caption byte 31
  /// Readings j = 0..29: X, Y, Z variations relative to the bias, nT.
  Eigen::Matrix<double, kLemiFlashReadingsPerBlock, 3> variation_nT =
      Eigen::Matrix<double, kLemiFlashReadingsPerBlock, 3>::Zero();
  /// Temperatures of each reading, deg C.
  Eigen::Matrix<double, kLemiFlashReadingsPerBlock, 1> sensor_temperature_C =
      Eigen::Matrix<double, kLemiFlashReadingsPerBlock, 1>::Zero();
  Eigen::Matrix<double, kLemiFlashReadingsPerBlock, 1> electronics_temperature_C =
      Eigen::Matrix<double, kLemiFlashReadingsPerBlock, 1>::Zero();
  std::uint64_t offset = 0;         ///< byte offset of the block in the file
};

/// Decodes 512 bytes; throws InputError("LEMI compact-flash block", problem) if the caption is
/// not valid (tag, BCD time).
LemiFlashBlock decode_lemi_flash_block(const std::uint8_t* bytes);
/// Encodes a block (tests and simulators). Throws InputError if a value does not fit.
std::array<std::uint8_t, kLemiFlashBlockSize> encode_lemi_flash_block(const LemiFlashBlock& block);

/// Reads every valid block; problems go to *warnings (if given). Throws InputError (above).
std::vector<LemiFlashBlock> read_lemi_flash_blocks(const std::string& path,
                                                   std::vector<std::string>* warnings = nullptr);

/// Compact flash as a 10 Hz VectorRecord (options.checksum and plausibility are not used: the
/// card has no checksum).
VectorRecord read_lemi_compact_flash(const std::string& path, const LemiReadOptions& options = {},
                                     std::vector<std::string>* warnings = nullptr);

/// The ten readings of second s (0..2) of a block as a packet-like group: gps_time_s =
/// block.time_s + s, readings 10 s .. 10 s + 9, temperatures of the group's first reading,
/// mode 1 (flash), DAC counts 0, flash free 0.
Lemi025Packet lemi_flash_block_second(const LemiFlashBlock& block, int second);

// ---- Raw stream capture and packets -----------------------------------------------------------

/// A raw capture of the serial byte stream as a 10 Hz VectorRecord.
VectorRecord read_lemi025_stream(const std::string& path, const LemiReadOptions& options = {},
                                 std::vector<std::string>* warnings = nullptr);

/// Packets to a 10 Hz VectorRecord: reading k of a packet at sample_time_s(k) + 0.3 +
/// options.time_shift_s, values per options.field; a reading not after the previous one is
/// dropped with a warning. Header: instrument, station_number, values, time_shift_s,
/// bias_changes (number of times the bias field changed), gps_not_active (packets whose GPS
/// status was not 'A').
VectorRecord lemi025_packets_to_record(const std::vector<Lemi025Packet>& packets,
                                       const LemiReadOptions& options = {},
                                       std::vector<std::string>* warnings = nullptr);

}  // namespace magnetometer_insitu_calibration
