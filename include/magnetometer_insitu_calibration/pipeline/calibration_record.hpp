// The calibration of one window as every output carries it: the MagnetometerCalibration message,
// the calibration file (YAML) and the calibrate_records JSON report. Its fields are defined once,
// in MIC_CALIBRATION_FIELDS below: the core record (CalibrationRecord), the message fill, the
// file's writer and reader and the JSON are all generated from that table, and a test checks that
// the message (msg/MagnetometerCalibration.msg) has exactly these fields and the header.
//
// Units: nT, seconds, Hz, degrees; *_ci95 are 95 % half-widths. Frames: each instrument's own;
// T = R n with rows as samples (column l of n is test axis l in reference coordinates).
#pragma once

#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/pipeline/window_calibration.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <string>

namespace magnetometer_insitu_calibration {

/// A time as ROS carries it: whole UNIX seconds and nanoseconds (the file keeps it exactly).
struct RecordTime {
  std::int64_t sec = 0;
  std::uint32_t nsec = 0;
  static RecordTime from_seconds(double unix_s);
  double seconds() const { return static_cast<double>(sec) + 1e-9 * static_cast<double>(nsec); }
  bool operator==(const RecordTime& o) const { return sec == o.sec && nsec == o.nsec; }
};

/// The kinds of field, with their C++ types in the core record.
namespace record_kind {
using Text = std::string;
using Time = RecordTime;
using Real = double;
using Count = std::uint32_t;
using Flag = bool;
using Quality = std::uint8_t;                 ///< Quality's value (0 = ok); JSON: its name
using Vector3 = std::array<double, 3>;        ///< x, y, z
using Pairs3 = std::array<double, 3>;         ///< xy, xz, yz (JSON: an object)
using Matrix9 = std::array<double, 9>;        ///< 3 x 3 row-major (JSON: rows)
using Matrix81 = std::array<double, 81>;      ///< 9 x 9 row-major (JSON: rows)
}  // namespace record_kind

/// The table: F(kind, name, since, comment), in the message's order. `since`: the calibration
/// file format that added the field (older files load with the defaults of calibration_yaml.cpp).
#define MIC_CALIBRATION_FIELDS(F)                                                                                  \
  F(Text, test_name, 1, "the test instrument's name")                                                              \
  F(Text, reference_frame_id, 1, "frame_id of the reference stream")                                               \
  F(Text, test_frame_id, 1, "frame_id of the test stream")                                                         \
  F(Time, window_start, 1, "first epoch of the window, UTC")                                                       \
  F(Time, window_end, 1, "last epoch of the window, UTC")                                                          \
  F(Real, sample_period, 1, "s, of the estimation grid")                                                           \
  F(Count, samples, 1, "samples estimated")                                                                        \
  F(Count, filled_samples, 1, "epochs without data: interpolated inside or missing at the edges")                  \
  F(Real, band_low_hz, 1, "requested band, Hz")                                                                    \
  F(Real, band_high_hz, 1, "requested band, Hz")                                                                   \
  F(Count, harmonic_first, 1, "DFT harmonics m0..m summed (Eq. 2)")                                                \
  F(Count, harmonic_last, 1, "")                                                                                   \
  F(Real, gamma, 1, "weights lambda^gamma")                                                                        \
  F(Flag, trend_column, 1, "linear-trend column in the regression")                                                \
  F(Text, method, 2, "estimator: robust or plain")                                                                 \
  F(Real, band_used_low_hz, 2, "band used, Hz")                                                                    \
  F(Real, band_used_high_hz, 2, "band used, Hz")                                                                   \
  F(Real, delay_s, 2, "test minus reference, s")                                                                   \
  F(Real, delay_ci95_s, 2, "s")                                                                                    \
  F(Matrix9, matrix, 1, "n, row-major, T = R n")                                                                   \
  F(Matrix81, matrix_covariance, 1, "9 x 9, row-major vec(n)")                                                     \
  F(Real, covariance_cells, 5, "spectral cells the covariance rests on (inf: taken as known)")                     \
  F(Real, interval_quantile, 5, "the parameters' ci95 in standard errors (Student's t at the cells)")              \
  F(Vector3, trend_nT_per_day, 1, "drift of the test against the reference, test frame")                           \
  F(Vector3, trend_ci95_nT_per_day, 1, "")                                                                         \
  F(Vector3, offset_nT, 2, "test relative to reference at window_end, test frame")                                 \
  F(Vector3, offset_ci95_nT, 2, "")                                                                                \
  F(Vector3, reference_mean_nT, 3, "mean(R) over the window, reference frame")                                     \
  F(Vector3, scale_ratio, 1, "K_test / K_ref per axis")                                                            \
  F(Vector3, scale_ratio_ci95, 1, "")                                                                              \
  F(Pairs3, nonorthogonality_deg, 1, "xy, xz, yz: 90 deg minus the angle between test axes")                       \
  F(Pairs3, nonorthogonality_ci95_deg, 1, "")                                                                      \
  F(Vector3, misalignment_deg, 1, "rotation about x, y, z of the orthogonal factor of n^T")                        \
  F(Vector3, misalignment_ci95_deg, 1, "")                                                                         \
  F(Vector3, axis_deviation_deg, 1, "angle between test axis l and reference axis l")                              \
  F(Vector3, axis_deviation_ci95_deg, 1, "")                                                                       \
  F(Real, condition_number, 1, "of the reference block of A")                                                      \
  F(Vector3, coherence, 1, "in-band share of the test's power explained by the reference")                         \
  F(Vector3, residual_rms_nT, 1, "in-band rms of the residual")                                                    \
  F(Quality, quality, 1, "first quality rule that failed; 0: ok")                                                  \
  F(Text, quality_text, 1, "")                                                                                     \
  F(Flag, accepted, 1, "quality ok: the window's calibration is used")                                             \
  F(Flag, temperature_fitted, 4, "temperature terms fitted")                                                       \
  F(Text, temperature_text, 4, "what was done, or why the terms were not fitted")                                  \
  F(Real, temperature_reference_C, 4, "degC: the window's mean temperature, n at it")                              \
  F(Real, temperature_range_C, 4, "degC")                                                                          \
  F(Vector3, temperature_apparent_nT_per_C, 4, "c + s F, test frame")                                              \
  F(Vector3, temperature_apparent_ci95_nT_per_C, 4, "")                                                            \
  F(Vector3, temperature_offset_nT_per_C, 4, "c")                                                                  \
  F(Vector3, temperature_offset_ci95_nT_per_C, 4, "")                                                              \
  F(Vector3, temperature_scale_ppm_per_C, 4, "s")                                                                  \
  F(Vector3, temperature_scale_ci95_ppm_per_C, 4, "")                                                              \
  F(Flag, remote_used, 6, "n from a remote reference's instruments (estimation/remote_reference.hpp)")             \
  F(Text, remote_text, 6, "what the remote did, or why it was refused; empty: no remote")                          \
  F(Vector3, remote_coherence, 6, "share of each local reference component the remote predicts")                   \
  F(Real, remote_strength, 6, "first-stage F of the remote's instruments (used from 10)")                          \
  F(Matrix9, pair_only_matrix, 6, "the pair-only estimate on the same cells (remote used)")                        \
  F(Real, pair_difference_p_value, 6, "joint p-value of the pair-only minus the remote estimate")                  \
  F(Flag, pair_biased, 6, "the pair alone is biased beyond its uncertainty")                                       \
  F(Real, band_split_p_value, 6, "without a remote: n of the band's halves compared, p-value")                     \
  F(Flag, band_split_differs, 6, "the halves differ: the pair-only window is not vouched for")                     \
  F(Text, scalar_text, 6, "the scalar check: what was found, or why not; empty: no scalar")                        \
  F(Real, reference_scale_along_field, 6, "1 / |c|, F = R c: the reference's absolute scale along the main field") \
  F(Real, reference_scale_along_field_ci95, 6, "")                                                                 \
  F(Vector3, direction_cosines, 6, "the main field's direction in the reference's frame, c / |c|")                 \
  F(Vector3, direction_cosines_ci95, 6, "")                                                                        \
  F(Real, test_scale_along_field, 6, "the test's scale along the field through n")                                 \
  F(Real, test_scale_along_field_ci95, 6, "")                                                                      \
  F(Flag, reference_needs_calibration, 6, "the reference's scale departs from 1 beyond its interval")         \
  F(Real, local_events_p_value, 7, "without a remote: events above the band the test does not follow, p-value")    \
  F(Flag, local_events_seen, 7, "such events seen: the pair-only window is not vouched for")

/// The calibration file's format: the largest `since` of the table.
constexpr int kCalibrationFileFormat = 7;

/// One window's calibration, every field of MIC_CALIBRATION_FIELDS, plus the header's stamp and
/// frame_id (the time the estimate was made, the reference frame).
struct CalibrationRecord {
#define MIC_DECLARE_FIELD(kind, name, since, comment) record_kind::kind name{};
  MIC_CALIBRATION_FIELDS(MIC_DECLARE_FIELD)
#undef MIC_DECLARE_FIELD
  RecordTime stamp;
  std::string frame_id;
};

/// Who and when a window's record is for.
struct RecordContext {
  std::string test_name = "test";
  std::string reference_frame_id, test_frame_id;
  RecordTime stamp;
  double sample_period_s = 1.0;  ///< of the estimation grid
  EstimatorSettings estimator;   ///< the requested band, gamma and trend column
};

/// The record of a calibrated window. Its quality is the estimate's, except that an ok window
/// whose n, covariance or offset is not finite is Quality::kNotFinite; accepted = quality ok.
CalibrationRecord make_calibration_record(const CalibrationWindow& window, const RecordContext& context);

/// The record as JSON, one key per field of the table: times as ISO 8601 strings (UTC, ms),
/// matrices as rows, non-orthogonality as {xy, xz, yz}, quality by name, non-finite values null.
nlohmann::json record_to_json(const CalibrationRecord& record);

/// The stream a calibration would correct: the node's test name ("" = not checked), the frame_id
/// of the stream's first sample and that sample's time.
struct StreamStart {
  std::string test_name;
  std::string test_frame_id;
  RecordTime first_sample;
};

/// Why a calibration held before a stream began (a file from an earlier run, or its latched
/// message) does not belong to that stream, naming the field; "" when it belongs. It belongs when
/// its test_name is the node's (when the node has one), its test_frame_id is the stream's, and its
/// window ended no later than the stream's first sample: a restart resumes the instrument's last
/// calibration whatever its age, but a calibration of another instrument or frame, or of data
/// after the stream's start (a replay of older data, or a second replay of one bag), is refused.
std::string calibration_stream_mismatch(const std::string& test_name, const std::string& test_frame_id,
                                        const RecordTime& window_end, const StreamStart& stream);

}  // namespace magnetometer_insitu_calibration
