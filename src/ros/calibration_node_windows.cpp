// calibration_node, window scheduling and estimation: the bounded queue of completed windows
// (callback thread -> worker), the worker thread with its own WindowEstimator, and per window
// the estimate, its publication (calibration_node_output.cpp) and the change check against the
// accepted calibration (see calibration_node.hpp).
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"

#include "calibration_node_channel.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include <chrono>
#include <sstream>

namespace magnetometer_insitu_calibration {

void CalibrationNode::submit(std::size_t index, WindowData&& window) {
  if (!coincident_) {
    enqueue(index, std::move(window));
    return;
  }
  for (CoincidentWindows::Released& r : coincident_->add(index, std::move(window))) {
    enqueue(r.channel, std::move(r.window), std::move(r.mate), r.mate_channel);
  }
}

void CalibrationNode::enqueue(std::size_t index, WindowData&& window, std::shared_ptr<const PairedRecord> mate,
                              std::size_t mate_channel) {
  Job job;
  job.channel = index;
  job.window = std::move(window);
  job.mate = std::move(mate);
  job.mate_channel = mate_channel;
  job.reference_frame_id = reference_.frame_id;
  job.test_frame_id = channels_[index]->test.frame_id;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    if (queue_.size() >= static_cast<std::size_t>(settings_.max_pending_windows)) {
      ++channels_[queue_.front().channel]->dropped_busy;
      queue_.pop_front();
    }
    queue_.push_back(std::move(job));
  }
  queue_cv_.notify_one();
}

void CalibrationNode::run_worker() {
  WindowEstimator estimator(settings_.estimator);  // this thread's own (FFTW plans and buffers)
  for (;;) {
    Job job;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      queue_cv_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      job = std::move(queue_.front());
      queue_.pop_front();
    }
    process(job, estimator);
  }
}

void CalibrationNode::process(Job& job, WindowEstimator& estimator) {
  Channel& ch = *channels_[job.channel];
  const TestInstrumentSettings& t = ch.settings;
  const double period = job.window.period_s;
  const double nominal_start = job.window.start_s, nominal_end = job.window.end_s();
  const std::string window_text = time_for_message(nominal_start) + " .. " + time_for_message(nominal_end);
  const auto started = std::chrono::steady_clock::now();
  WindowResult result;
  IdentifiedNoise reference_noise;  // the hat's or the pair's result, when active
  try {
    if (coincident_) {
      result = estimate_window_with_hat(std::move(job.window), job.mate.get(),
                                        "test '" + channels_[job.mate_channel]->settings.name + "'", estimator,
                                        settings_.gap_rule, reference_noise);
    } else if (settings_.pair_noise_active()) {
      result = estimate_window_with_pair_noise(std::move(job.window), estimator, settings_.gap_rule, reference_noise);
    } else {
      result = estimate_window(std::move(job.window), estimator, settings_.gap_rule);
    }
  } catch (const std::exception& e) {
    ROS_ERROR("%s: test '%s': window %s could not be prepared: %s", node_name_.c_str(), t.name.c_str(),
              window_text.c_str(), e.what());
    std::lock_guard<std::mutex> lock(ch.results_mutex);
    ++ch.failed;
    ch.last_failed = true;
    ch.last_failure = window_text + ": " + e.what();
    return;
  }
  const WindowEstimate& e = result.estimate;
  const MagnetometerCalibration m = calibration_message(job, result, period);
  const std::string file_error = publish_calibration(ch, m);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  ROS_INFO("%s: test '%s': window %s: %s (%s; %u samples, %u missing; %.3f s)", node_name_.c_str(), t.name.c_str(),
           window_text.c_str(), m.accepted ? "accepted" : "rejected", m.quality_text.c_str(), m.samples,
           m.filled_samples, seconds);

  std::lock_guard<std::mutex> lock(ch.results_mutex);
  // Change check of this window against the accepted calibration (before it may become it).
  if (ch.baseline) {
    ch.last_change = check_calibration_change(*ch.baseline, e, settings_.change);
    ch.last_change_window = window_text;
    ch.change_checked = true;
    if (ch.last_change.status == CalibrationChangeStatus::kChanged) {
      ++ch.changes_detected;
      ROS_WARN("%s: test '%s': window %s: %s", node_name_.c_str(), t.name.c_str(), window_text.c_str(),
               ch.last_change.text.c_str());
    }
  } else if (m.accepted) {
    ch.baseline = std::make_unique<WindowEstimate>(e);
    ch.baseline_window = window_text;
    ch.baseline_source = "first window accepted since start";
  }
  {
    std::ostringstream band, offset;
    band << m.band_used_low_hz << " .. " << m.band_used_high_hz;
    offset.precision(6);
    for (int k = 0; k < 3; ++k) offset << (k ? " " : "") << m.offset_nT[k];
    offset << " (95 % +-";
    for (int k = 0; k < 3; ++k) offset << " " << m.offset_ci95_nT[k];
    offset << ")";
    ch.last_band = band.str();
    ch.last_offset = offset.str();
  }
  ch.last_temperature = m.temperature_text;
  ch.last_response_model = result.response_model.text;
  ch.response_model_applied_windows += result.response_model.applied;
  ch.last_temperature_apparent.clear();
  if (m.temperature_fitted) {
    ++ch.temperature_fitted_windows;
    std::ostringstream apparent;
    apparent.precision(4);
    for (int k = 0; k < 3; ++k) apparent << (k ? " " : "") << m.temperature_apparent_nT_per_C[k];
    apparent << " (95 % +-";
    for (int k = 0; k < 3; ++k) apparent << " " << m.temperature_apparent_ci95_nT_per_C[k];
    apparent << ") at " << m.temperature_reference_C << " degC";
    ch.last_temperature_apparent = apparent.str();
  }
  ch.last_method = m.method;
  ch.last_eiv = e.eiv;
  ch.last_reference_noise = reference_noise.text;
  ch.last_weights = e.weights;
  ch.spikes_removed += result.spikes;
  ch.last_intervals = e.intervals;
  ch.hat_identified_windows += e.eiv.find("three-cornered hat") != std::string::npos ? 1 : 0;
  ch.pair_identified_windows += e.eiv.find("from the pair above the band") != std::string::npos ? 1 : 0;
  ch.last_response = result.response;
  ch.last_delay_s = m.delay_s;
  ch.last_delay_ci95_s = m.delay_ci95_s;
  ++ch.estimated;
  ch.last_failed = false;
  ch.last_window = window_text;
  ch.last_quality = std::string(quality_name(static_cast<Quality>(m.quality))) + ": " + m.quality_text;
  ch.last_accepted = m.accepted;
  ch.last_duration_s = seconds;
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
