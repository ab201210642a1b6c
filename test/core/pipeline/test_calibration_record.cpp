// The calibration record (pipeline/calibration_record.hpp): a window whose every value is known
// goes field by field into the record, and the record into JSON with one key per field of the
// table, in the forms the header states.
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_record.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>
#include <string>

namespace mic = magnetometer_insitu_calibration;

namespace {

/// A window with a distinct value in every place the record reads.
mic::CalibrationWindow known_window() {
  mic::CalibrationWindow w;
  w.start_s = 1747180800.0;  // 2025-05-14T00:00:00Z
  w.end_s = w.start_s + 3599.0;
  w.leading_missing = 2;
  w.interpolated = 5;
  mic::WindowEstimate& e = w.estimate;
  e.samples = 3598;
  e.sample_period_s = 1.0;
  e.harmonic_first = 1;
  e.harmonic_last = 36;
  for (int k = 0; k < 9; ++k) e.n(k / 3, k % 3) = 1.0 + 0.01 * k;
  for (int k = 0; k < 81; ++k) e.n_covariance(k / 9, k % 9) = 1e-9 * (k + 1);
  e.covariance_dof = 27.5;
  e.parameters.interval_quantile = 2.05;
  e.trend_nT_per_day = {0.5, -0.25, 2.0};
  e.trend_stderr_nT_per_day = {1.0, 2.0, 3.0};
  e.parameters.scale_ratio = {1.001, 0.999, 1.002};
  e.parameters.nonorthogonality_deg = {0.1, 0.2, 0.3};
  e.parameters.misalignment_deg = {-0.4, 0.5, -0.6};
  e.condition_number = 3.5;
  e.coherence = {0.99, 0.98, 0.97};
  e.method = "robust";
  e.band_low_hz = 0.0003;
  e.band_high_hz = 0.01;
  e.delay_s = 2.86;
  e.delay_ci95_s = 0.01;
  w.offset_end_nT = {10.0, -20.0, 30.0};
  w.offset_end_ci95_nT = {0.1, 0.2, 0.3};
  w.reference_mean_nT = {21000.0, 100.0, 43000.0};
  w.temperature.text = "no thermometer";
  return w;
}

mic::RecordContext known_context() {
  mic::RecordContext c;
  c.test_name = "fge";
  c.reference_frame_id = "lemi036";
  c.test_frame_id = "fge_link";
  c.stamp = mic::RecordTime{1747184400, 250000000};
  c.sample_period_s = 1.0;
  c.estimator.band_low_hz = 0.0002;
  c.estimator.band_high_hz = 0.01;
  c.estimator.gamma = 1.0;
  c.estimator.trend = true;
  return c;
}

}  // namespace

TEST(CalibrationRecord, CarriesTheWindowFieldByField) {
  const mic::CalibrationRecord r = mic::make_calibration_record(known_window(), known_context());
  EXPECT_EQ(r.test_name, "fge");
  EXPECT_EQ(r.frame_id, "lemi036");
  EXPECT_EQ(r.test_frame_id, "fge_link");
  EXPECT_EQ(r.stamp, (mic::RecordTime{1747184400, 250000000}));
  EXPECT_EQ(r.window_start, (mic::RecordTime{1747180800, 0}));
  EXPECT_EQ(r.window_end, (mic::RecordTime{1747184399, 0}));
  EXPECT_EQ(r.samples, 3598u);
  EXPECT_EQ(r.filled_samples, 7u);
  EXPECT_EQ(r.band_low_hz, 0.0002);  // requested
  EXPECT_EQ(r.band_used_low_hz, 0.0003);
  EXPECT_EQ(r.harmonic_last, 36u);
  EXPECT_TRUE(r.trend_column);
  EXPECT_EQ(r.method, "robust");
  // n and its covariance row-major: matrix[3 r + c] = n(r, c).
  EXPECT_EQ(r.matrix[5], 1.05);
  EXPECT_DOUBLE_EQ(r.matrix_covariance[80], 81e-9);
  EXPECT_EQ(r.covariance_cells, 27.5);
  EXPECT_EQ(r.interval_quantile, 2.05);
  // The trend's half-width: the normal quantile (its own sample count is large).
  EXPECT_NEAR(r.trend_ci95_nT_per_day[2], 1.959964 * 3.0, 1e-5);
  EXPECT_EQ(r.offset_nT[1], -20.0);
  EXPECT_EQ(r.reference_mean_nT[2], 43000.0);
  EXPECT_EQ(r.nonorthogonality_deg[2], 0.3);
  EXPECT_EQ(r.quality, 0);
  EXPECT_TRUE(r.accepted);
  // No temperature: coefficients, reference and range NaN, the text says why.
  EXPECT_FALSE(r.temperature_fitted);
  EXPECT_EQ(r.temperature_text, "no thermometer");
  EXPECT_TRUE(std::isnan(r.temperature_reference_C));
  EXPECT_TRUE(std::isnan(r.temperature_scale_ppm_per_C[0]));
}

TEST(CalibrationRecord, AnOkWindowWithoutAFiniteOffsetIsNotAccepted) {
  mic::CalibrationWindow w = known_window();
  w.offset_end_nT(1) = std::numeric_limits<double>::quiet_NaN();
  mic::CalibrationRecord r = mic::make_calibration_record(w, known_context());
  EXPECT_EQ(r.quality, static_cast<std::uint8_t>(mic::Quality::kNotFinite));
  EXPECT_EQ(r.quality_text, "offset not finite");
  EXPECT_FALSE(r.accepted);
  w = known_window();
  w.estimate.n_covariance(3, 3) = std::numeric_limits<double>::infinity();
  r = mic::make_calibration_record(w, known_context());
  EXPECT_EQ(r.quality_text, "matrix or covariance not finite");
  // A window that failed a rule keeps its own quality.
  w.estimate.quality = mic::Quality::kGaps;
  w.estimate.quality_text = "gap of 700 s";
  r = mic::make_calibration_record(w, known_context());
  EXPECT_EQ(r.quality, static_cast<std::uint8_t>(mic::Quality::kGaps));
  EXPECT_EQ(r.quality_text, "gap of 700 s");
  EXPECT_FALSE(r.accepted);
}

TEST(CalibrationRecord, JsonHasOneKeyPerFieldOfTheTable) {
  const nlohmann::json j = mic::record_to_json(mic::make_calibration_record(known_window(), known_context()));
  std::set<std::string> table;
#define MIC_NAME(kind, name, since, comment) table.insert(#name);
  MIC_CALIBRATION_FIELDS(MIC_NAME)
#undef MIC_NAME
  std::set<std::string> keys;
  for (const auto& item : j.items()) keys.insert(item.key());
  EXPECT_EQ(keys, table);
  EXPECT_EQ(j["window_start"], "2025-05-14T00:00:00.000Z");
  EXPECT_EQ(j["window_end"], "2025-05-14T00:59:59.000Z");
  EXPECT_EQ(j["matrix"][1][2], 1.05);
  EXPECT_DOUBLE_EQ(j["matrix_covariance"][8][8].get<double>(), 81e-9);
  EXPECT_EQ(j["nonorthogonality_deg"]["yz"], 0.3);
  EXPECT_EQ(j["quality"], "ok");
  EXPECT_TRUE(j["temperature_reference_C"].is_null());  // NaN
  EXPECT_TRUE(j["temperature_scale_ppm_per_C"][0].is_null());
  EXPECT_EQ(j["accepted"], true);
  EXPECT_EQ(j["filled_samples"], 7);
}

TEST(CalibrationRecord, TimesKeepTheirNanoseconds) {
  for (const double t : {1747180800.0, 1747180800.1, 1747180800.999999999, 0.5}) {
    const mic::RecordTime r = mic::RecordTime::from_seconds(t);
    EXPECT_LT(r.nsec, 1000000000u) << t;
    EXPECT_NEAR(r.seconds(), t, 1e-6) << t;
  }
  EXPECT_EQ(mic::RecordTime::from_seconds(1747180800.9999999999), (mic::RecordTime{1747180801, 0}));
}

TEST(CalibrationStreamMismatch, ACalibrationBelongsToItsInstrumentFrameAndEarlierTimeOnly) {
  const mic::RecordTime first{1747180800, 500000000};  // 2025-05-14T00:00:00.5Z
  const mic::StreamStart stream{"fge", "fge_frame", first};
  // A restart: the same instrument's calibration of a window that ended an hour or a year before,
  // or exactly at the first sample, belongs.
  EXPECT_EQ(mic::calibration_stream_mismatch("fge", "fge_frame", {first.sec - 3600, 0}, stream), "");
  EXPECT_EQ(mic::calibration_stream_mismatch("fge", "fge_frame", {first.sec - 365 * 86400, 0}, stream), "");
  EXPECT_EQ(mic::calibration_stream_mismatch("fge", "fge_frame", first, stream), "");
  // Another instrument or frame, named with both values.
  EXPECT_EQ(mic::calibration_stream_mismatch("lemi", "fge_frame", {first.sec - 3600, 0}, stream),
            "test_name 'lemi' is not this node's 'fge'");
  EXPECT_EQ(mic::calibration_stream_mismatch("fge", "test", {first.sec - 3600, 0}, stream),
            "test_frame_id 'test' is not the stream's 'fge_frame'");
  // A node without a test name checks the frame and the time only.
  EXPECT_EQ(mic::calibration_stream_mismatch("lemi", "fge_frame", {first.sec - 3600, 0}, {"", "fge_frame", first}), "");
  // A window ending 1 ns or a day after the first sample: data the stream has not reached.
  EXPECT_EQ(mic::calibration_stream_mismatch("fge", "fge_frame", {first.sec, first.nsec + 1}, stream),
            "window_end 2025-05-14T00:00:00.500Z is after the stream's first sample 2025-05-14T00:00:00.500Z "
            "(a calibration of later data)");
  const std::string later = mic::calibration_stream_mismatch("fge", "fge_frame", {first.sec + 86400, 0}, stream);
  EXPECT_EQ(later.rfind("window_end 2025-05-15T00:00:00", 0), 0u) << later;
}
