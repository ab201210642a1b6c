// calibration_node, windows: the bounded queue of completed windows (callback thread -> worker),
// the worker thread with its own WindowCalibrator, and per window the per-window stage, its
// publication (calibration_node_output.cpp) and the change check against the accepted
// calibration (see calibration_node.hpp).
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"

#include "calibration_node_channel.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include <chrono>
#include <cstdio>

namespace magnetometer_insitu_calibration {

void CalibrationNode::enqueue(std::vector<LiveCalibrationStreams::Completed> windows) {
  if (windows.empty()) return;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    for (LiveCalibrationStreams::Completed& completed : windows) {
      Job job;
      job.channel = completed.test;
      job.window = std::move(completed.window);
      job.reference_frame_id = reference_.frame_id;
      job.test_frame_id = channels_[completed.test]->test.frame_id;
      if (queue_.size() >= static_cast<std::size_t>(settings_.max_pending_windows)) {
        ++channels_[queue_.front().channel]->dropped_busy;
        queue_.pop_front();
      }
      queue_.push_back(std::move(job));
    }
  }
  queue_cv_.notify_one();
}

void CalibrationNode::run_worker() {
  WindowCalibrator calibrator(settings_.window);  // this thread's own (FFTW plans and buffers)
  for (;;) {
    Job job;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      queue_cv_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      job = std::move(queue_.front());
      queue_.pop_front();
    }
    process(job, calibrator);
  }
}

void CalibrationNode::process(Job& job, WindowCalibrator& calibrator) {
  Channel& ch = *channels_[job.channel];
  const std::string window_text = time_for_message(job.window.start_s) + " .. " + time_for_message(job.window.end_s());
  const auto started = std::chrono::steady_clock::now();
  CalibrationWindow result;
  try {
    result = calibrator.calibrate(std::move(job.window));
  } catch (const std::exception& e) {
    ROS_ERROR("%s: test '%s': window %s could not be prepared: %s", node_name_.c_str(), ch.settings.name.c_str(),
              window_text.c_str(), e.what());
    std::lock_guard<std::mutex> lock(ch.results_mutex);
    ++ch.failed;
    ch.last_failed = true;
    ch.last_failure = window_text + ": " + e.what();
    return;
  }
  const MagnetometerCalibration m = calibration_message(job, result);
  const std::string file_error = publish_calibration(ch, m);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  // With a scalar magnetometer, the reference's own check on the same line.
  char scalar[96] = "";
  if (result.scalar.assessed) {
    std::snprintf(scalar, sizeof scalar, "; reference along F %.5f +- %.5f%s", result.scalar.reference_scale,
                  result.scalar.reference_scale_ci95, result.scalar.reference_off ? ", needs calibration" : "");
  }
  ROS_INFO("%s: test '%s': window %s: %s (%s; %u samples, %u missing; %.3f s%s)", node_name_.c_str(),
           ch.settings.name.c_str(), window_text.c_str(), m.accepted ? "accepted" : "rejected", m.quality_text.c_str(),
           m.samples, m.filled_samples, seconds, scalar);

  std::lock_guard<std::mutex> lock(ch.results_mutex);
  const WindowEstimate& e = result.estimate;
  // Change check of this window against the accepted calibration (before it may become it).
  if (ch.baseline) {
    ch.last_change = check_calibration_change(*ch.baseline, e, settings_.change);
    ch.last_change_window = window_text;
    ch.change_checked = true;
    if (ch.last_change.status == CalibrationChangeStatus::kChanged) {
      ++ch.changes_detected;
      ROS_WARN("%s: test '%s': window %s: %s", node_name_.c_str(), ch.settings.name.c_str(), window_text.c_str(),
               ch.last_change.text.c_str());
    }
  } else if (m.accepted) {
    ch.baseline = std::make_unique<WindowEstimate>(e);
    ch.baseline_window = window_text;
    ch.baseline_source = "first window accepted since start";
  }
  const bool corrected = e.eiv == ErrorsInVariables::kApplied;
  ch.hat_windows += corrected && e.eiv_noise.source == NoiseSource::kThreeCorneredHat;
  ch.pair_windows += corrected && e.eiv_noise.source == NoiseSource::kPairAboveBand;
  ch.model_applied_windows += result.response_model.applied;
  ch.temperature_fitted_windows += result.temperature.fitted;
  ch.last = std::move(result);
  ch.last_window = window_text;
  ch.last_quality = std::string(quality_name(static_cast<Quality>(m.quality))) + ": " + m.quality_text;
  ch.last_accepted = m.accepted;
  ch.last_duration_s = seconds;
  ch.last_failed = false;
  ++ch.estimated;
  if (m.accepted) {
    ++ch.accepted;
    ch.last_accepted_window = window_text;
    ch.last_accepted_stamp = time_for_message(m.header.stamp.toSec());
    ch.file_error = file_error;
    if (file_error.empty()) ++ch.files_written;
  } else {
    ++ch.flagged;
  }
}

}  // namespace magnetometer_insitu_calibration
