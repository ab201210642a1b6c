// calibration_node, output: the MagnetometerCalibration message of a window estimate, the YAML
// file of the latest accepted calibration (written before the message is published), and the
// resume of that file at start (see calibration_node.hpp). Units: nT inside and in the message's
// *_nT fields; the matrix n is dimensionless (T = R n, rows are samples).
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"

#include "calibration_node_channel.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <limits>

namespace magnetometer_insitu_calibration {

namespace {

static_assert(static_cast<int>(Quality::kOk) == MagnetometerCalibration::QUALITY_OK &&
                  static_cast<int>(Quality::kTooFewSamples) == MagnetometerCalibration::QUALITY_TOO_FEW_SAMPLES &&
                  static_cast<int>(Quality::kTooFewHarmonics) == MagnetometerCalibration::QUALITY_TOO_FEW_HARMONICS &&
                  static_cast<int>(Quality::kIllConditioned) == MagnetometerCalibration::QUALITY_ILL_CONDITIONED &&
                  static_cast<int>(Quality::kLowCoherence) == MagnetometerCalibration::QUALITY_LOW_COHERENCE &&
                  static_cast<int>(Quality::kGaps) == MagnetometerCalibration::QUALITY_GAPS &&
                  static_cast<int>(Quality::kNotFinite) == MagnetometerCalibration::QUALITY_NOT_FINITE,
              "Quality and the message's QUALITY_* constants must agree");

template <typename Array>
void copy3(Array& out, const Eigen::Vector3d& v) {
  for (int i = 0; i < 3; ++i) out[i] = v(i);
}

}  // namespace

MagnetometerCalibration CalibrationNode::calibration_message(const Job& job, const CalibrationWindow& result) const {
  const double period = settings_.streams.estimation_period_s();
  const TestInstrumentSettings& t = channels_[job.channel]->settings;
  const WindowEstimate& e = result.estimate;
  MagnetometerCalibration m;
  m.header.stamp = ros::Time::now();
  m.header.frame_id = job.reference_frame_id;
  m.test_name = t.name;
  m.reference_frame_id = job.reference_frame_id;
  m.test_frame_id = job.test_frame_id;
  m.window_start = ros::Time().fromSec(result.start_s);
  m.window_end = ros::Time().fromSec(result.end_s);
  m.sample_period = period;
  m.samples = static_cast<std::uint32_t>(e.samples);
  m.filled_samples = static_cast<std::uint32_t>(result.missing());
  m.band_low_hz = settings_.window.estimator.band_low_hz;
  m.band_high_hz = settings_.window.estimator.band_high_hz;
  m.harmonic_first = static_cast<std::uint32_t>(std::max(0, e.harmonic_first));
  m.harmonic_last = static_cast<std::uint32_t>(std::max(0, e.harmonic_last));
  m.gamma = settings_.window.estimator.gamma;
  m.trend_column = settings_.window.estimator.trend;
  m.method = e.method;
  m.band_used_low_hz = e.band_low_hz;
  m.band_used_high_hz = e.band_high_hz;
  m.delay_s = e.delay_s;
  m.delay_ci95_s = e.delay_ci95_s;
  copy3(m.offset_nT, result.offset_end_nT);
  copy3(m.reference_mean_nT, result.reference_mean_nT);
  copy3(m.offset_ci95_nT, result.offset_end_ci95_nT);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m.matrix[vec_index(r, c)] = e.n(r, c);
  }
  for (int r = 0; r < 9; ++r) {
    for (int c = 0; c < 9; ++c) m.matrix_covariance[9 * r + c] = e.n_covariance(r, c);
  }
  m.covariance_cells = e.covariance_dof;
  m.interval_quantile = e.parameters.interval_quantile;
  copy3(m.trend_nT_per_day, e.trend_nT_per_day);
  copy3(m.trend_ci95_nT_per_day, kNormalQuantile95 * e.trend_stderr_nT_per_day);
  const CalibrationParameters& p = e.parameters;
  copy3(m.scale_ratio, p.scale_ratio);
  copy3(m.scale_ratio_ci95, p.scale_ratio_ci95);
  copy3(m.nonorthogonality_deg, p.nonorthogonality_deg);
  copy3(m.nonorthogonality_ci95_deg, p.nonorthogonality_ci95_deg);
  copy3(m.misalignment_deg, p.misalignment_deg);
  copy3(m.misalignment_ci95_deg, p.misalignment_ci95_deg);
  copy3(m.axis_deviation_deg, p.axis_deviation_deg);
  copy3(m.axis_deviation_ci95_deg, p.axis_deviation_ci95_deg);
  m.condition_number = e.condition_number;
  copy3(m.coherence, e.coherence);
  copy3(m.residual_rms_nT, e.residual_rms_nT);
  // Temperature terms (NaN coefficients when not fitted; reference and range when known).
  const TemperatureFit& f = result.temperature;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Eigen::Vector3d none = Eigen::Vector3d::Constant(nan);
  m.temperature_fitted = f.fitted;
  m.temperature_text = f.text;
  m.temperature_reference_C = result.temperature_known ? f.reference_C : nan;
  m.temperature_range_C = result.temperature_known ? f.range_C : nan;
  copy3(m.temperature_apparent_nT_per_C, f.fitted ? f.apparent_nT_per_C : none);
  copy3(m.temperature_apparent_ci95_nT_per_C, f.fitted ? f.apparent_ci95_nT_per_C : none);
  copy3(m.temperature_offset_nT_per_C, f.fitted ? f.offset_nT_per_C : none);
  copy3(m.temperature_offset_ci95_nT_per_C, f.fitted ? f.offset_ci95_nT_per_C : none);
  copy3(m.temperature_scale_ppm_per_C, f.fitted ? f.scale_ppm_per_C : none);
  copy3(m.temperature_scale_ci95_ppm_per_C, f.fitted ? f.scale_ci95_ppm_per_C : none);
  m.quality = static_cast<std::uint8_t>(e.quality);
  m.quality_text = e.quality_text;
  if (e.quality == Quality::kOk && !(e.n.allFinite() && e.n_covariance.allFinite())) {
    m.quality = MagnetometerCalibration::QUALITY_NOT_FINITE;
    m.quality_text = "matrix or covariance not finite";
  }
  if (m.quality == MagnetometerCalibration::QUALITY_OK && !result.offset_end_nT.allFinite()) {
    m.quality = MagnetometerCalibration::QUALITY_NOT_FINITE;
    m.quality_text = "offset not finite";
  }
  m.accepted = m.quality == MagnetometerCalibration::QUALITY_OK;
  return m;
}

std::string CalibrationNode::publish_calibration(Channel& ch, const MagnetometerCalibration& m) {
  const TestInstrumentSettings& t = ch.settings;
  // The file first, so that whoever sees the accepted message finds it on disk.
  std::string file_error;
  if (m.accepted) {
    try {
      write_file_atomically(t.calibration_file, calibration_to_yaml(m, node_name_));
    } catch (const std::exception& error) {
      file_error = error.what();
      ROS_ERROR("%s: test '%s': calibration file not written: %s", node_name_.c_str(), t.name.c_str(), error.what());
    }
  }
  ch.publisher.publish(m);
  publish_rotation(ch, m);
  return file_error;
}

void CalibrationNode::resume_from_file(Channel& ch) {
  const TestInstrumentSettings& t = ch.settings;
  struct stat info {};
  if (::stat(t.calibration_file.c_str(), &info) != 0) {
    ch.resume_state = "no calibration file at start";
    return;
  }
  try {
    MagnetometerCalibration m = load_calibration_file(t.calibration_file);
    std::string reason;
    if (!m.accepted || m.quality != MagnetometerCalibration::QUALITY_OK) reason = "not an accepted calibration";
    if (reason.empty() && m.test_name != t.name) reason = "written for test '" + m.test_name + "'";
    auto e = std::make_unique<WindowEstimate>();
    for (int k = 0; k < 9; ++k) e->n(k / 3, k % 3) = m.matrix[k];
    for (int k = 0; k < 81; ++k) e->n_covariance(k / 9, k % 9) = m.matrix_covariance[k];
    if (reason.empty() && !(e->n.allFinite() && e->n_covariance.allFinite())) reason = "matrix or covariance not finite";
    if (!reason.empty()) {
      ch.resume_state = "calibration file not resumed: " + reason;
      ROS_WARN("%s: test '%s': %s (%s)", node_name_.c_str(), t.name.c_str(), ch.resume_state.c_str(),
               t.calibration_file.c_str());
      return;
    }
    e->samples = m.samples;
    e->sample_period_s = m.sample_period;
    e->quality = Quality::kOk;
    e->method = m.method;
    e->covariance_dof = m.covariance_cells;  // infinite from a file of format 4 or older: taken as known
    e->parameters = decompose(e->n, e->n_covariance, e->covariance_dof);
    const std::string window = time_for_message(m.window_start.toSec()) + " .. " + time_for_message(m.window_end.toSec());
    ch.baseline = std::move(e);
    ch.baseline_window = window;
    ch.baseline_source = "file (loaded at start)";
    ch.last_accepted_window = window;
    ch.last_accepted_stamp = time_for_message(m.header.stamp.toSec());
    ch.resume_state = "resumed from file";
    ch.publisher.publish(m);  // latched: subscribers get the persisted calibration at once
    publish_rotation(ch, m);  // with ~publish_tf, its rotation on /tf_static (also latched)
    ROS_INFO("%s: test '%s': resumed the accepted calibration of window %s from %s", node_name_.c_str(),
             t.name.c_str(), window.c_str(), t.calibration_file.c_str());
  } catch (const std::exception& error) {
    ch.resume_state = std::string("calibration file not resumed: ") + error.what();
    ROS_WARN("%s: test '%s': %s", node_name_.c_str(), t.name.c_str(), ch.resume_state.c_str());
  }
}

}  // namespace magnetometer_insitu_calibration
