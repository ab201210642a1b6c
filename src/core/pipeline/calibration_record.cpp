// The calibration record of a window and its JSON: see calibration_record.hpp.
#include "magnetometer_insitu_calibration/pipeline/calibration_record.hpp"

#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "json_number.hpp"

#include <cmath>
#include <limits>

namespace magnetometer_insitu_calibration {

RecordTime RecordTime::from_seconds(double unix_s) {
  RecordTime t;
  if (!std::isfinite(unix_s)) return t;
  t.sec = static_cast<std::int64_t>(std::floor(unix_s));
  long long nsec = std::llround((unix_s - static_cast<double>(t.sec)) * 1e9);
  if (nsec >= 1000000000LL) {
    ++t.sec;
    nsec -= 1000000000LL;
  }
  t.nsec = static_cast<std::uint32_t>(nsec);
  return t;
}

namespace {

record_kind::Vector3 array3(const Eigen::Vector3d& v) { return {v(0), v(1), v(2)}; }

/// The temperature terms' fields (NaN coefficients when not fitted; reference and range when
/// the temperature was known).
void fill_temperature(CalibrationRecord& r, const CalibrationWindow& w) {
  const TemperatureFit& f = w.temperature;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Eigen::Vector3d none = Eigen::Vector3d::Constant(nan);
  r.temperature_fitted = f.fitted;
  r.temperature_text = f.text;
  r.temperature_reference_C = w.temperature_known ? f.reference_C : nan;
  r.temperature_range_C = w.temperature_known ? f.range_C : nan;
  r.temperature_apparent_nT_per_C = array3(f.fitted ? f.apparent_nT_per_C : none);
  r.temperature_apparent_ci95_nT_per_C = array3(f.fitted ? f.apparent_ci95_nT_per_C : none);
  r.temperature_offset_nT_per_C = array3(f.fitted ? f.offset_nT_per_C : none);
  r.temperature_offset_ci95_nT_per_C = array3(f.fitted ? f.offset_ci95_nT_per_C : none);
  r.temperature_scale_ppm_per_C = array3(f.fitted ? f.scale_ppm_per_C : none);
  r.temperature_scale_ci95_ppm_per_C = array3(f.fitted ? f.scale_ci95_ppm_per_C : none);
}

/// The remote reference's fields (NaN where there is no remote, or it was not used).
void fill_remote(CalibrationRecord& r, const RemoteReference& remote) {
  r.remote_used = remote.used;
  r.remote_text = remote.text;
  r.remote_coherence = array3(remote.coherence);
  r.remote_strength = remote.strength;
  for (int k = 0; k < 9; ++k) r.pair_only_matrix[static_cast<std::size_t>(k)] = remote.pair_n(k / 3, k % 3);
  r.pair_difference_p_value = remote.joint_p_value;
  r.pair_biased = remote.pair_biased;
}

/// The estimate's fields: n, its covariance and cells, trend, parameters, quality figures.
void fill_estimate(CalibrationRecord& r, const WindowEstimate& e) {
  for (int k = 0; k < 9; ++k) r.matrix[static_cast<std::size_t>(k)] = e.n(k / 3, k % 3);
  for (int k = 0; k < 81; ++k) r.matrix_covariance[static_cast<std::size_t>(k)] = e.n_covariance(k / 9, k % 9);
  r.covariance_cells = e.covariance_dof;
  r.interval_quantile = e.parameters.interval_quantile;
  r.trend_nT_per_day = array3(e.trend_nT_per_day);
  r.trend_ci95_nT_per_day = array3(kNormalQuantile95 * e.trend_stderr_nT_per_day);
  const CalibrationParameters& p = e.parameters;
  r.scale_ratio = array3(p.scale_ratio);
  r.scale_ratio_ci95 = array3(p.scale_ratio_ci95);
  r.nonorthogonality_deg = array3(p.nonorthogonality_deg);
  r.nonorthogonality_ci95_deg = array3(p.nonorthogonality_ci95_deg);
  r.misalignment_deg = array3(p.misalignment_deg);
  r.misalignment_ci95_deg = array3(p.misalignment_ci95_deg);
  r.axis_deviation_deg = array3(p.axis_deviation_deg);
  r.axis_deviation_ci95_deg = array3(p.axis_deviation_ci95_deg);
  r.condition_number = e.condition_number;
  r.coherence = array3(e.coherence);
  r.residual_rms_nT = array3(e.residual_rms_nT);
  r.method = e.method;
  r.band_used_low_hz = e.band_low_hz;
  r.band_used_high_hz = e.band_high_hz;
  r.delay_s = e.delay_s;
  r.delay_ci95_s = e.delay_ci95_s;
  r.samples = static_cast<std::uint32_t>(e.samples);
  r.harmonic_first = static_cast<std::uint32_t>(std::max(0, e.harmonic_first));
  r.harmonic_last = static_cast<std::uint32_t>(std::max(0, e.harmonic_last));
}

}  // namespace

CalibrationRecord make_calibration_record(const CalibrationWindow& w, const RecordContext& context) {
  CalibrationRecord r;
  r.stamp = context.stamp;
  r.frame_id = context.reference_frame_id;
  r.test_name = context.test_name;
  r.reference_frame_id = context.reference_frame_id;
  r.test_frame_id = context.test_frame_id;
  r.window_start = RecordTime::from_seconds(w.start_s);
  r.window_end = RecordTime::from_seconds(w.end_s);
  r.sample_period = context.sample_period_s;
  r.filled_samples = static_cast<std::uint32_t>(w.missing());
  r.band_low_hz = context.estimator.band_low_hz;
  r.band_high_hz = context.estimator.band_high_hz;
  r.gamma = context.estimator.gamma;
  r.trend_column = context.estimator.trend;
  fill_estimate(r, w.estimate);
  r.offset_nT = array3(w.offset_end_nT);
  r.offset_ci95_nT = array3(w.offset_end_ci95_nT);
  r.reference_mean_nT = array3(w.reference_mean_nT);
  fill_temperature(r, w);
  const WindowEstimate& e = w.estimate;
  r.quality = static_cast<std::uint8_t>(e.quality);
  r.quality_text = e.quality_text;
  if (e.quality == Quality::kOk && !(e.n.allFinite() && e.n_covariance.allFinite())) {
    r.quality = static_cast<std::uint8_t>(Quality::kNotFinite);
    r.quality_text = "matrix or covariance not finite";
  } else if (e.quality == Quality::kOk && !w.offset_end_nT.allFinite()) {
    r.quality = static_cast<std::uint8_t>(Quality::kNotFinite);
    r.quality_text = "offset not finite";
  }
  r.accepted = r.quality == static_cast<std::uint8_t>(Quality::kOk);
  fill_remote(r, e.remote);
  r.band_split_p_value = e.band_split.p_value;
  r.band_split_differs = e.band_split.differs;
  r.local_events_p_value = e.local_events.p_value;
  r.local_events_seen = e.local_events.seen;
  const ScalarCheck& s = w.scalar;
  r.scalar_text = s.text;
  r.reference_scale_along_field = s.reference_scale;
  r.reference_scale_along_field_ci95 = s.reference_scale_ci95;
  r.direction_cosines = array3(s.direction_cosines);
  r.direction_cosines_ci95 = array3(s.direction_cosines_ci95);
  r.test_scale_along_field = s.test_scale;
  r.test_scale_along_field_ci95 = s.test_scale_ci95;
  r.reference_needs_calibration = s.reference_off;
  return r;
}

namespace {

using nlohmann::json;

using json_detail::number;

// One JSON form per kind of field (calibration_record.hpp).
json json_of_Text(const record_kind::Text& v) { return v; }
json json_of_Time(const record_kind::Time& v) {
  try {
    return format_iso8601(v.seconds(), 3);
  } catch (const std::exception&) {
    return nullptr;
  }
}
json json_of_Real(record_kind::Real v) { return number(v); }
json json_of_Count(record_kind::Count v) { return v; }
json json_of_Flag(record_kind::Flag v) { return v; }
json json_of_Quality(record_kind::Quality v) { return quality_name(static_cast<Quality>(v)); }
json json_of_Vector3(const record_kind::Vector3& v) { return json::array({number(v[0]), number(v[1]), number(v[2])}); }
json json_of_Pairs3(const record_kind::Pairs3& v) {
  return json{{"xy", number(v[0])}, {"xz", number(v[1])}, {"yz", number(v[2])}};
}
template <std::size_t N>
json rows_of(const std::array<double, N>& v, std::size_t columns) {
  json out = json::array();
  for (std::size_t r = 0; r < N / columns; ++r) {
    json row = json::array();
    for (std::size_t c = 0; c < columns; ++c) row.push_back(number(v[r * columns + c]));
    out.push_back(row);
  }
  return out;
}
json json_of_Matrix9(const record_kind::Matrix9& v) { return rows_of(v, 3); }
json json_of_Matrix81(const record_kind::Matrix81& v) { return rows_of(v, 9); }

}  // namespace

json record_to_json(const CalibrationRecord& r) {
  json out = json::object();
#define MIC_FIELD_TO_JSON(kind, name, since, comment) out[#name] = json_of_##kind(r.name);
  MIC_CALIBRATION_FIELDS(MIC_FIELD_TO_JSON)
#undef MIC_FIELD_TO_JSON
  return out;
}

std::string calibration_stream_mismatch(const std::string& test_name, const std::string& test_frame_id,
                                        const RecordTime& window_end, const StreamStart& stream) {
  if (!stream.test_name.empty() && test_name != stream.test_name) {
    return "test_name '" + test_name + "' is not this node's '" + stream.test_name + "'";
  }
  if (test_frame_id != stream.test_frame_id) {
    return "test_frame_id '" + test_frame_id + "' is not the stream's '" + stream.test_frame_id + "'";
  }
  const bool later = window_end.sec > stream.first_sample.sec ||
                     (window_end.sec == stream.first_sample.sec && window_end.nsec > stream.first_sample.nsec);
  if (later) {
    return "window_end " + time_for_message(window_end.seconds()) + " is after the stream's first sample " +
           time_for_message(stream.first_sample.seconds()) + " (a calibration of later data)";
  }
  return "";
}

}  // namespace magnetometer_insitu_calibration
