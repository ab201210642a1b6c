// calibration_node, diagnostics (/diagnostics, every ~diagnostic_period of ROS time): the
// reference stream, and per test instrument its stream, pairing, windows, last estimate, file
// and change check (see calibration_node.hpp).
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"

#include "calibration_node_channel.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/common/time_steps.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_summary.hpp"
#include "magnetometer_insitu_calibration/ros/parameters.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>
#include <utility>

namespace magnetometer_insitu_calibration {

using diagnostic_msgs::DiagnosticStatus;
using diagnostic_updater::DiagnosticStatusWrapper;

namespace {

/// A field stream's keys after its topic, each name after `prefix` ("" for the reference,
/// "test " for a test): frame, messages, newest stamp, stamp jumps, stray stamps, and the ROS
/// time since its last message (s), which it returns.
double add_stream_keys(const StreamMonitor& m, const std::string& prefix, double now_s, double started_s,
                       DiagnosticStatusWrapper& status) {
  status.add(prefix + "frame_id", m.frame_id);
  status.add(prefix + "messages", m.messages);
  status.add(prefix + "newest stamp", m.messages > 0 ? time_for_message(m.newest_stamp_s) : std::string("none"));
  status.add(prefix + "stamp jumps forward", m.jumps_forward);
  status.add(prefix + "stamp jumps backward", m.jumps_backward);
  status.add(prefix + "stray stamps", m.stray);
  status.add(prefix + "measured period (s)", m.measured_period_s());
  const double silence = m.silence_s(now_s, started_s);
  status.add(prefix + "silent for (s)", silence);
  return silence;
}

/// The warning of a silent stream (`silence` s of ROS time; `name` "reference" or "test").
std::string silence_problem(const StreamMonitor& m, const std::string& name, double silence) {
  return m.messages > 0 ? name + " topic silent for " + number_text(std::round(silence)) + " s"
                        : "no " + name + " message yet";
}

/// The scalar check of the last window: its text, and its numbers (NaN where not determined).
void describe_scalar(const ScalarCheck& f, DiagnosticStatusWrapper& status) {
  status.add("scalar check (last window)", f.text);
  status.add("reference scale along the field", f.reference_scale);
  status.add("reference scale along the field ci95", f.reference_scale_ci95);
  for (int l = 0; l < 3; ++l) {
    const std::string axis(1, "xyz"[l]);
    status.add("reference scale " + axis + " (given direction)", f.axis_scale(l));
    status.add("reference scale " + axis + " ci95 (given direction)", f.axis_scale_ci95(l));
  }
  status.add("fitted direction from the given (deg)", f.direction_offset_deg);
  status.add("fitted direction from the given ci95 (deg)", f.direction_offset_ci95_deg);
}

/// The last window's estimate in words: method, noise model, weights, band, delay, offset,
/// response, response model and temperature terms.
void describe_window(const CalibrationWindow& w, DiagnosticStatusWrapper& status) {
  const WindowEstimate& e = w.estimate;
  std::ostringstream band, offset, apparent;
  band << e.band_low_hz << " .. " << e.band_high_hz;
  offset.precision(6);
  for (int k = 0; k < 3; ++k) offset << (k ? " " : "") << w.offset_end_nT(k);
  offset << " (95 % +-";
  for (int k = 0; k < 3; ++k) offset << " " << w.offset_end_ci95_nT(k);
  offset << ")";
  status.add("method", e.method);
  status.add("EIV (last window)", e.eiv_text());
  status.add("reference noise (last window)", w.reference_noise.text.empty() ? std::string("none identified")
                                                                             : w.reference_noise.text);
  status.add("weights (last window)", e.weights);
  status.add("intervals (last window)", e.intervals);
  status.add("last band used (Hz)", band.str());
  status.add("last delay (s)", e.delay_s);
  status.add("last delay ci95 (s)", e.delay_ci95_s);
  status.add("last offset at window end (nT)", offset.str());
  status.add("temperature terms (last window)", w.temperature.text);
  if (w.temperature.fitted) {
    apparent.precision(4);
    for (int k = 0; k < 3; ++k) apparent << (k ? " " : "") << w.temperature.apparent_nT_per_C(k);
    apparent << " (95 % +-";
    for (int k = 0; k < 3; ++k) apparent << " " << w.temperature.apparent_ci95_nT_per_C(k);
    apparent << ") at " << w.temperature.reference_C << " degC";
  }
  status.add("temperature apparent coefficients (nT/degC)", apparent.str());
  status.add("response model (last window)", w.response_model.text);
  status.add("remote reference (last window)", e.remote.given ? e.remote.text : std::string("none"));
  status.add("band split (last window)", e.remote.used ? std::string("not needed (remote)") : e.band_split.text);
  status.add("local events (last window)", e.remote.used ? std::string("not needed (remote)") : e.local_events.text);
  if (!w.scalar.text.empty()) describe_scalar(w.scalar, status);
  // Relative frequency response of the test against R n over the band used (relative_response.hpp).
  if (w.response.bands > 0) {
    status.add("response bands in the band used", w.response.bands);
    status.add("response largest |gain - 1| in the band", w.response.max_gain_departure);
    status.add("response largest |gain - 1| ci95", w.response.max_gain_departure_ci95);
    status.add("response group delay (s)", w.response.group_delay_s);
  }
}

/// The last change check (check_calibration_change) of window `window` against the accepted
/// calibration: status, chi2 and p-values, largest z per parameter kind, the text.
void describe_change(const std::string& window, const CalibrationChange& change, DiagnosticStatusWrapper& status) {
  status.add("change check window", window);
  status.add("change status", calibration_change_status_name(change.status));
  status.add("change chi2 (9 dof)", change.chi2);
  status.add("change p-value", change.p_value);
  status.add("change decided by", change.joint_tested ? "joint test (9 entries of n)"
                                                      : "parameters one by one (covariances from few cells)");
  status.add("change smallest parameter p-value", change.parameter_p_value);
  status.add("change max z (scale)", change.scale_z.maxCoeff());
  status.add("change max z (nonorthogonality)", change.nonorthogonality_z.maxCoeff());
  status.add("change max z (misalignment)", change.misalignment_z.maxCoeff());
  status.add("change text", change.text);
}

}  // namespace

void CalibrationNode::diagnose_reference(DiagnosticStatusWrapper& status) {
  const double now = ros::Time::now().toSec();
  if (started_s_ == 0.0 && now > 0.0) started_s_ = now;
  status.summary(DiagnosticStatus::OK, "receiving");
  status.add("topic", nh_.resolveName(reference_.topic));
  const double silence = add_stream_keys(reference_, "", now, started_s_, status);
  if (started_s_ > 0.0 && silence > settings_.silent_timeout_s) {
    status.mergeSummary(DiagnosticStatus::WARN, silence_problem(reference_, "reference", silence));
  }
  const std::string period = period_mismatch(reference_, settings_.streams.input_period_s, "reference", "~input_period");
  if (!period.empty()) status.mergeSummary(DiagnosticStatus::ERROR, period);
  if (const LiveScalarStream* f = streams_->scalar()) {  // the scalar magnetometer's stream
    status.add("scalar topic", nh_.resolveName(scalar_.topic));
    const double scalar_silence = add_stream_keys(scalar_, "scalar ", now, started_s_, status);
    status.add("scalar refused (stamp not after the last)", f->refused);
    if (started_s_ > 0.0 && scalar_silence > settings_.silent_timeout_s) {
      status.mergeSummary(DiagnosticStatus::WARN, silence_problem(scalar_, "scalar", scalar_silence));
    }
  }
  if (remote_.topic.empty()) return;  // the remote observatory's stream beside the reference's
  status.add("remote topic", nh_.resolveName(remote_.topic));
  const double remote_silence = add_stream_keys(remote_, "remote ", now, started_s_, status);
  if (started_s_ > 0.0 && remote_silence > settings_.silent_timeout_s) {
    status.mergeSummary(DiagnosticStatus::WARN, silence_problem(remote_, "remote", remote_silence));
  }
  const std::string remote_period =
      period_mismatch(remote_, settings_.streams.remote_period_s(), "remote", "~remote_input_period");
  if (!remote_period.empty()) status.mergeSummary(DiagnosticStatus::ERROR, remote_period);
  if (const SideStream* r = streams_->remote()) {
    status.add("remote epoch alignment", epoch_alignment_name(r->alignment()));
    status.add("remote decimator restarts", r->restarts());
    status.add("windows waiting for the remote", streams_->waiting_for_remote());  // up to ~remote_max_wait
    const std::string phase = phase_mismatch(remote_, r->alignment(), "remote");
    if (!phase.empty()) status.mergeSummary(DiagnosticStatus::ERROR, phase);
  }
}

std::string CalibrationNode::period_mismatch(const StreamMonitor& monitor, double nominal_s, const std::string& stream,
                                             const std::string& parameter) {
  const std::string problem = monitor.period_problem(nominal_s);
  if (problem.empty()) return "";
  const std::string text = stream + " " + problem + " (" + parameter + "): give the stream's period";
  if (problems_logged_.insert(stream).second) ROS_ERROR("%s: %s", node_name_.c_str(), text.c_str());
  return text;
}

std::string CalibrationNode::phase_mismatch(const StreamMonitor& monitor, EpochAlignment alignment,
                                            const std::string& stream) {
  if (alignment == EpochAlignment::kEachFiltered) return "";  // filtered onto the epochs: any phase
  const double period = settings_.streams.input_period_s;
  const double offset = phase_offset_s(monitor.stamp_phase_s(period), reference_.stamp_phase_s(period), period);
  if (!std::isfinite(offset) || std::abs(offset) <= settings_.streams.pairing_tolerance_s) return "";
  char text[240];
  std::snprintf(text, sizeof text,
                "%s stamps fall %+.3g s off the reference's in each %g s, beyond ~pairing_tolerance (%g s): nothing "
                "pairs; give ~stamps_apart true",
                stream.c_str(), offset, period, settings_.streams.pairing_tolerance_s);
  if (problems_logged_.insert(stream + " phase").second) ROS_ERROR("%s: %s", node_name_.c_str(), text);
  return text;
}

void CalibrationNode::diagnose_channel(std::size_t index, DiagnosticStatusWrapper& status) {
  Channel& ch = *channels_[index];
  const double now = ros::Time::now().toSec();
  if (started_s_ == 0.0 && now > 0.0) started_s_ = now;
  status.summary(DiagnosticStatus::OK, "ok");
  Problems problems;
  status.add("test topic", nh_.resolveName(ch.test.topic));
  status.add("calibration topic", nh_.resolveName(ch.settings.calibration_topic));
  status.add("calibration file", ch.settings.calibration_file);
  const double silence = add_stream_keys(ch.test, "test ", now, started_s_, status);
  if (started_s_ > 0.0 && silence > settings_.silent_timeout_s) {
    problems.emplace_back(DiagnosticStatus::WARN, silence_problem(ch.test, "test", silence));
  }
  const std::string period =
      period_mismatch(ch.test, streams_->test(index).input_period_s, "test '" + ch.settings.name + "'",
                      ch.settings.input_period_s > 0.0 ? "its input_period in ~tests" : "~test_input_period, else ~input_period");
  if (!period.empty()) problems.emplace_back(DiagnosticStatus::ERROR, period);
  const std::string phase = phase_mismatch(ch.test, streams_->test(index).alignment, "test '" + ch.settings.name + "'");
  if (!phase.empty()) problems.emplace_back(DiagnosticStatus::ERROR, phase);
  diagnose_stream(index, status, problems);
  diagnose_results(ch, status, problems);
  for (const auto& problem : problems) status.mergeSummary(problem.first, problem.second);
}

void CalibrationNode::diagnose_stream(std::size_t index, DiagnosticStatusWrapper& status, Problems& problems) {
  Channel& ch = *channels_[index];
  const LiveTestStream& stream = streams_->test(index);
  const PairingCounters c = stream.counters();
  status.add("paired", c.paired);
  status.add("unpaired reference", c.unpaired_reference);
  status.add("unpaired test", c.unpaired_test);
  status.add("late", c.late);
  status.add("duplicates", c.duplicates);
  status.add("invalid stamps", c.invalid);
  status.add("pending reference", stream.pairer.pending_reference());
  status.add("pending test", stream.pairer.pending_test());
  if (c.late > ch.reported_late || c.duplicates > ch.reported_duplicates) {
    problems.emplace_back(DiagnosticStatus::WARN, std::to_string(c.late - ch.reported_late) + " late and " +
                                                      std::to_string(c.duplicates - ch.reported_duplicates) +
                                                      " duplicate samples since the last report");
  }
  ch.reported_late = c.late;
  ch.reported_duplicates = c.duplicates;
  status.add("despiking", settings_.streams.despike);
  status.add("spikes removed (reference, test)", std::to_string(streams_->reference_spikes()) + ", " +
                                                     std::to_string(stream.despiker.spikes()));
  status.add("epoch alignment", epoch_alignment_name(stream.alignment));
  status.add("decimator restarts", stream.decimator_restarts);
  status.add("pipeline resets (stamps backwards)", stream.pipeline_resets);
  status.add("buffered samples", stream.windows.buffered());
  // The thermometer (temperature terms).
  const std::string& temperature_topic = ch.settings.temperature_topic;
  status.add("temperature topic", temperature_topic.empty() ? std::string("none") : nh_.resolveName(temperature_topic));
  if (!temperature_topic.empty()) {
    status.add("temperature samples", ch.temperature_messages);
    status.add("temperature samples buffered", stream.thermometer.buffered());
    status.add("temperature samples out of order", stream.thermometer.out_of_order());
    status.add("temperature last (degC)", ch.temperature_last_C);
    status.add("temperature last stamp",
               ch.temperature_messages > 0 ? time_for_message(ch.temperature_last_stamp_s) : std::string("none"));
  }
  status.add("windows queued", stream.windows.windows_emitted());
  status.add("windows skipped (no data)", stream.windows.windows_skipped_empty());
  const std::size_t dropped = ch.dropped_busy.load();
  status.add("windows dropped (worker busy)", dropped);
  if (dropped > ch.reported_dropped) {
    problems.emplace_back(DiagnosticStatus::WARN, std::to_string(dropped - ch.reported_dropped) +
                                                      " windows dropped: estimator busy");
  }
  ch.reported_dropped = dropped;
  std::size_t pending = 0;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    for (const Job& job : queue_) pending += job.channel == index;
  }
  status.add("windows pending", pending);
}

void CalibrationNode::diagnose_results(Channel& ch, DiagnosticStatusWrapper& status, Problems& problems) {
  std::lock_guard<std::mutex> lock(ch.results_mutex);
  status.add("windows estimated", ch.estimated);
  status.add("windows accepted", ch.accepted);
  status.add("windows flagged", ch.flagged);
  status.add("windows failed", ch.failed);
  status.add("last window", ch.last_window.empty() ? std::string("none") : ch.last_window);
  status.add("last window quality", ch.last_quality);
  status.add("last window accepted", ch.last_accepted);
  status.add("last estimate duration (s)", ch.last_duration_s);
  status.add("last accepted window", ch.last_accepted_window.empty() ? std::string("none") : ch.last_accepted_window);
  status.add("last accepted stamp", ch.last_accepted_stamp);
  status.add("calibration files written", ch.files_written);
  status.add("reference noise model", settings_.noise_model_state());
  status.add("windows corrected with the hat's reference noise", ch.hat_windows);
  status.add("windows corrected with the pair's reference noise", ch.pair_windows);
  status.add("windows estimated through a modelled filter", ch.model_applied_windows);
  status.add("windows with temperature terms", ch.temperature_fitted_windows);
  if (ch.last) describe_window(*ch.last, status);
  status.add("resume at start", ch.resume_state);
  status.add("loaded from file", ch.resume_state == "resumed from file");
  status.add("accepted calibration (change check)", ch.baseline ? ch.baseline_window : std::string("none"));
  status.add("accepted calibration source", ch.baseline_source);
  status.add("calibration changes detected", ch.changes_detected);
  if (ch.change_checked) {
    describe_change(ch.last_change_window, ch.last_change, status);
    if (ch.last_change.status == CalibrationChangeStatus::kChanged) {
      problems.emplace_back(DiagnosticStatus::WARN, "calibration changed: " + ch.last_change.text);
    }
  }
  status.add("tf state", ch.tf_state);
  status.add("tf transforms published", ch.tf_published);
  status.add("tf rotation angle (deg)", ch.tf_angle_deg);
  status.add("calibration file error", ch.file_error);
  if (ch.last_failed) problems.emplace_back(DiagnosticStatus::ERROR, "window failed: " + ch.last_failure);
  if (ch.last && ch.last->estimate.remote.pair_biased) {
    problems.emplace_back(DiagnosticStatus::WARN, "the pair alone is biased (a remote sees it)");
  }
  if (ch.last) {
    const std::string doubt = not_vouched_for(ch.last->estimate);
    if (!doubt.empty()) {
      problems.emplace_back(DiagnosticStatus::WARN, "not vouched for: " + doubt + "; give a remote reference");
    }
  }
  if (!ch.file_error.empty()) problems.emplace_back(DiagnosticStatus::ERROR, "file not written: " + ch.file_error);
  if (ch.last && ch.last->scalar.reference_off) {
    problems.emplace_back(DiagnosticStatus::WARN, "the reference needs calibration: its scale along the field departs "
                                                  "from 1 beyond its interval (scalar check)");
  }
  // Until this stream's first accepted window replaces it, the file is another stream's.
  if (ch.accepted == 0 && ch.resume_refused) {
    problems.emplace_back(DiagnosticStatus::WARN, ch.resume_state);
  }
  if (ch.estimated > 0 && !ch.last_accepted && !ch.last_failed) {
    problems.emplace_back(DiagnosticStatus::WARN, "last window rejected (" + ch.last_quality + ")");
  }
}

void CalibrationNode::diagnose_tolerances(std::size_t index, DiagnosticStatusWrapper& status) {
  Channel& ch = *channels_[index];
  std::lock_guard<std::mutex> lock(ch.results_mutex);
  status.summary(DiagnosticStatus::OK, "no window yet");
  status.add("tolerances", settings_.window.tolerances.source);
  if (!ch.last || ch.last->verdicts.empty()) return;
  status.summary(DiagnosticStatus::OK, "within its tolerances");
  for (const VerdictGroup& g : group_verdicts(ch.last->verdicts)) {
    status.add(g.name + " (last window)", g.text);
    if (g.worst == Verdict::kOutside) status.mergeSummary(DiagnosticStatus::ERROR, g.name + " outside its tolerance");
    if (g.worst == Verdict::kUndecided) status.mergeSummary(DiagnosticStatus::WARN, g.name + " undecided");
  }
  status.add("intervals narrow (last window)", ch.last->narrowing.text);
  const std::string doubt = not_vouched_for(ch.last->estimate);
  if (!doubt.empty()) status.mergeSummary(DiagnosticStatus::WARN, "verdicts not vouched for: " + doubt);
}

}  // namespace magnetometer_insitu_calibration
