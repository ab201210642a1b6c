// calibration_node, output: the MagnetometerCalibration message of a window's record, the YAML
// file of the latest accepted calibration (written before the message is published), and the
// resume of that file at start (see calibration_node.hpp). Units: nT inside and in the message's
// *_nT fields; the matrix n is dimensionless (T = R n, rows are samples).
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"

#include "calibration_node_channel.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/ros/calibration_message.hpp"
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"

#include <sys/stat.h>


namespace magnetometer_insitu_calibration {

MagnetometerCalibration CalibrationNode::calibration_message(const Job& job, const CalibrationWindow& result) const {
  RecordContext context;
  context.test_name = channels_[job.channel]->settings.name;
  context.reference_frame_id = job.reference_frame_id;
  context.test_frame_id = job.test_frame_id;
  const ros::Time now = ros::Time::now();
  context.stamp = RecordTime{now.sec, now.nsec};
  context.sample_period_s = settings_.streams.estimation_period_s();
  context.estimator = settings_.window.estimator;
  MagnetometerCalibration m = to_message(make_calibration_record(result, context));
  set_verdicts(m, result.verdicts);
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
    ch.resumed_unchecked = m;
    ch.publisher.publish(m);  // latched: subscribers get the persisted calibration at once
    publish_rotation(ch, m);  // with ~publish_tf, its rotation on /tf_static (also latched)
    ROS_INFO("%s: test '%s': resumed the accepted calibration of window %s from %s", node_name_.c_str(),
             t.name.c_str(), window.c_str(), t.calibration_file.c_str());
  } catch (const std::exception& error) {
    ch.resume_state = std::string("calibration file not resumed: ") + error.what();
    ROS_WARN("%s: test '%s': %s", node_name_.c_str(), t.name.c_str(), ch.resume_state.c_str());
  }
}

void CalibrationNode::drop_resumed_if_not_of_stream(Channel& ch, const sensor_msgs::MagneticField& first) {
  if (!ch.resumed_unchecked) return;
  const MagnetometerCalibration m = *ch.resumed_unchecked;
  ch.resumed_unchecked.reset();
  const std::string reason = calibration_stream_mismatch(
      m.test_name, m.test_frame_id, RecordTime{m.window_end.sec, m.window_end.nsec},
      {ch.settings.name, first.header.frame_id, RecordTime{first.header.stamp.sec, first.header.stamp.nsec}});
  if (reason.empty()) return;
  // The file's message, latched since the start, is replaced at once by its retraction (before
  // the diagnostics report the refusal): a subscriber connecting later must not get another
  // stream's calibration as accepted.
  MagnetometerCalibration retraction = m;
  retraction.accepted = false;
  retraction.quality_text = "calibration file refused at the stream's first sample, not of this stream: " + reason;
  ch.publisher.publish(retraction);
  // No window can have been estimated before the stream's first sample: the baseline is the file's.
  std::lock_guard<std::mutex> lock(ch.results_mutex);
  ch.baseline.reset();
  ch.baseline_window.clear();
  ch.baseline_source = "none";
  ch.last_accepted_window.clear();
  ch.last_accepted_stamp.clear();
  ch.resume_state = "resumed file refused, not of this stream: " + reason;
  ch.resume_refused = true;
  ROS_WARN("%s: test '%s': the calibration resumed from %s is refused at the stream's first sample and retracted "
           "(published again with accepted false): %s",
           node_name_.c_str(), ch.settings.name.c_str(), ch.settings.calibration_file.c_str(), reason.c_str());
}

}  // namespace magnetometer_insitu_calibration
