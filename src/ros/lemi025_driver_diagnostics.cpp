// lemi025_driver, diagnostics: the /diagnostics tasks "packet rate", "link" (connection, parser
// and publishing counters) and "instrument" (GPS status, time source, supply, temperatures, bias
// field), and the timer that publishes them (see lemi025_driver.hpp).
#include "magnetometer_insitu_calibration/ros/lemi025_driver.hpp"

#include "lemi025_driver_internal.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/ros/parameters.hpp"

#include <limits>

namespace magnetometer_insitu_calibration {

using namespace lemi025_driver_detail;
using diagnostic_msgs::DiagnosticStatus;
using diagnostic_updater::DiagnosticStatusWrapper;

void Lemi025Driver::setup_diagnostics() {
  const Lemi025DriverSettings& s = settings_;
  // Expected packet rate: 1/s live (~expected_packet_rate, e.g. a simulator's --speed), ~rate
  // for a paced replay, anything for an unpaced one.
  if (!s.recorded()) {
    min_frequency_ = max_frequency_ = s.expected_packet_rate;
  } else if (s.rate > 0.0) {
    min_frequency_ = max_frequency_ = s.rate;
  } else {
    min_frequency_ = 0.0;
    max_frequency_ = std::numeric_limits<double>::infinity();
  }
  frequency_ = std::make_unique<diagnostic_updater::FrequencyStatus>(
      diagnostic_updater::FrequencyStatusParam(&min_frequency_, &max_frequency_, 0.1, 5), "packet rate");
  updater_.setHardwareID(description_);
  updater_.add("packet rate", [this](DiagnosticStatusWrapper& status) {
    frequency_->run(status);
    std::lock_guard<std::mutex> lock(mutex_);
    if (state_.at_end) status.summary(DiagnosticStatus::OK, "end of recording");
  });
  updater_.add("link", [this](DiagnosticStatusWrapper& status) { diagnose_link(status); });
  updater_.add("instrument", [this](DiagnosticStatusWrapper& status) { diagnose_instrument(status); });
  // Wall time: the driver's health is reported in real time, also under a paused or stepped
  // simulated /clock (the message stamps stay ros::Time::now()).
  diagnostic_timer_ = nh_.createWallTimer(ros::WallDuration(s.diagnostic_period_s),
                                          [this](const ros::WallTimerEvent&) { updater_.force_update(); });
}

void Lemi025Driver::diagnose_link(DiagnosticStatusWrapper& status) {
  State st;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    st = state_;
  }
  const Lemi025ParserStats& p = st.stats.parser;
  status.summary(DiagnosticStatus::OK, st.connected ? "connected" : "not connected");
  status.add("source", description_);
  status.add("connected", st.connected);
  status.add("end of recording", st.at_end);
  status.add("packets", st.packets_received);
  status.add("bytes read", p.bytes_fed);
  status.add("checksum errors", p.checksum_errors);
  status.add("resyncs", p.resyncs);
  status.add("bytes skipped", p.bytes_skipped);
  status.add("time jumps", p.time_jumps);
  status.add("disconnects", st.stats.disconnects);
  status.add("reconnects", st.stats.reconnects);
  status.add("reopen attempts", st.stats.reopen_attempts);
  status.add("last disconnect", st.last_disconnect.empty() ? std::string("none") : st.last_disconnect);
  status.add("connection problem", st.connected ? std::string() : st.connection_problem);
  status.add("disconnected for (s)", st.connected || st.disconnected_since_wall_s < 0.0
                                         ? std::string("0")
                                         : number_text(wall_now_s() - st.disconnected_since_wall_s));
  status.add("readings published", st.readings_published);
  status.add("readings published as NaN (invalid)", st.readings_invalid);
  status.add("readings dropped (stamp not after the previous)", st.readings_dropped_time);
  status.add("readings dropped (no GPS, gps_required)", st.readings_dropped_gps);
  status.add("readings dropped (no usable time)", st.readings_bad_time);
  status.add("packets dropped (isolated GPS time jump)", st.packets_dropped_unconfirmed);
  status.add("GPS time jumps confirmed", st.gps_jumps_confirmed);
  status.add("PC clock steps", st.pc_clock_steps);
  status.add("last PC clock step (s)", st.pc_clock_steps > 0 ? number_text(st.last_pc_clock_step_s) : std::string("none"));
  status.add("last published stamp", st.readings_published > 0 ? time_for_message(st.last_stamp_s) : std::string("none"));
  status.add("last warning", st.last_warning);

  if (st.at_end) status.summary(DiagnosticStatus::OK, "end of recording");
  if (!st.connected && !st.at_end) {
    status.mergeSummary(DiagnosticStatus::ERROR,
                        "disconnected: reopening every " + number_text(settings_.reopen_interval_s) + " s (" +
                            std::to_string(st.stats.reopen_attempts) + " attempts" +
                            (st.connection_problem.empty() ? std::string() : ", " + st.connection_problem) + ")");
  }
  auto report = [&status](std::uint64_t now, std::uint64_t& reported, const std::string& what) {
    if (now > reported) status.mergeSummary(DiagnosticStatus::WARN, std::to_string(now - reported) + " " + what);
    reported = now;
  };
  report(p.checksum_errors, reported_checksum_, "checksum errors");
  report(p.resyncs, reported_resyncs_, "resyncs (bytes skipped)");
  report(p.time_jumps, reported_time_jumps_, "time jumps");
  if (st.connected) report(st.stats.disconnects, reported_disconnects_, "disconnects (reconnected)");
  report(st.readings_dropped_time, reported_dropped_, "readings dropped: stamp not after the previous");
  report(st.packets_dropped_unconfirmed, reported_unconfirmed_, "packets dropped: isolated GPS time jump");
  report(st.pc_clock_steps, reported_pc_steps_, "PC clock steps (stamps restarted from the PC clock)");
}

void Lemi025Driver::diagnose_instrument(DiagnosticStatusWrapper& status) {
  State st;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    st = state_;
  }
  if (!st.have_packet) {
    status.summary(DiagnosticStatus::WARN, "no packet yet");
    return;
  }
  const Lemi025Packet& last = st.last;
  status.summary(DiagnosticStatus::OK, "GPS time");
  status.add("model", lemi_model_name(last.model));
  status.add("station", static_cast<int>(last.station));
  status.add("GPS status", gps_status_text(last.gps_status));
  status.add("time source", st.time_source);
  status.add("packets without GPS", st.packets_without_gps);
  status.add("last GPS time", time_for_message(last.gps_time_s));
  status.add("supply voltage (V)", last.supply_V);
  status.add("sensor temperature (degC)", last.sensor_temperature_C);
  status.add("electronics temperature (degC)", last.electronics_temperature_C);
  status.add("bias field X Y Z (nT)", vector_text(last.bias_nT));
  status.add("bias changes", st.bias_changes);
  status.add("last bias change", st.last_bias_change.empty() ? std::string("none") : st.last_bias_change);
  status.add("mode", static_cast<int>(last.mode));
  status.add("flash free (%)", static_cast<int>(last.flash_free_percent));

  if (last.gps_status != 'A') {
    if (settings_.gps_required) {
      status.mergeSummary(DiagnosticStatus::ERROR, "GPS status " + gps_status_text(last.gps_status) +
                                                       ": readings not published (~gps_required)");
    } else {
      status.mergeSummary(DiagnosticStatus::WARN,
                          "GPS status " + gps_status_text(last.gps_status) + ": stamps from the " + st.time_source);
    }
  }
  if (st.last_bias_change_wall_s >= 0.0 && wall_now_s() - st.last_bias_change_wall_s < kBiasChangeWarningHold_s) {
    status.mergeSummary(DiagnosticStatus::WARN, "bias field changed: " + st.last_bias_change);
  }
  if (settings_.min_supply_V > 0.0 && last.supply_V < settings_.min_supply_V) {
    status.mergeSummary(DiagnosticStatus::WARN, "supply voltage " + number_text(last.supply_V) + " V below " +
                                                    number_text(settings_.min_supply_V) + " V");
  }
}

}  // namespace magnetometer_insitu_calibration
