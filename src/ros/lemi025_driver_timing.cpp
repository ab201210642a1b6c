// lemi025_driver, packet timing: the stamps of each packet's readings (GPS time, or the PC clock
// at arrival when GPS is not active: PcPacketClock), the screening of isolated GPS time jumps
// (held packets), stamps that never go backwards, and the publishing of readings and
// temperatures (see "Time stamps" in lemi025_driver.hpp).
#include "magnetometer_insitu_calibration/ros/lemi025_driver.hpp"

#include "lemi025_driver_internal.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/ros/parameters.hpp"

#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/Temperature.h>

#include <cmath>
#include <limits>

namespace magnetometer_insitu_calibration {

using namespace lemi025_driver_detail;

// ---------------------------------------------------------------------------------------------
// PC clock

double PcPacketClock::first_reading_time(double arrival_s) {
  const double measured = arrival_s - (kLemi025ReadingsPerPacket - 1) * kLemi025SamplePeriod_s;
  if (have_previous_) {
    const double predicted = previous_s_ + 1.0;
    const double difference = measured - predicted;
    if (std::abs(difference) <= 0.5) {
      previous_s_ = predicted + 0.1 * difference;
      return previous_s_;
    }
    // The PC clock stepped (NTP correction, operator, suspend) or packets stopped coming for
    // a while: restart from the arrival time.
    ++steps_;
    last_step_s_ = difference;
  }
  have_previous_ = true;
  previous_s_ = measured;
  return measured;
}

// ---------------------------------------------------------------------------------------------
// GPS-time screening and publishing

void Lemi025Driver::handle(const Lemi025Packet& packet, double arrival_s, double recorded_pc_s) {
  frequency_->tick();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++state_.packets_received;
  }
  // GPS-time screening (see "Isolated GPS time jumps" in the header). Packets on any other time
  // source count as slots but are never held.
  ++slots_since_reference_;
  for (HeldPacket& h : held_) ++h.slots;
  const double g = packet.gps_time_s;
  if (packet.gps_status != 'A' || !std::isfinite(g)) {
    drop_held(held_.size(), "a packet without GPS time came next");
    publish_packet(packet, arrival_s, recorded_pc_s);
    return;
  }
  // Consistent with x (a GPS second n packets ago): after it, and not further ahead than the n
  // seconds that n packets take.
  auto consistent = [g](double x, std::uint64_t n) { return g > x && g <= x + static_cast<double>(n); };
  if (have_gps_reference_ && consistent(gps_reference_s_, slots_since_reference_)) {
    // The clock runs on from the reference: every held packet was an outlier.
    drop_held(held_.size(), "the packets after it continue from the time before it");
    accept_gps(packet, arrival_s, recorded_pc_s);
    return;
  }
  for (std::size_t i = held_.size(); i-- > 0;) {
    if (!consistent(held_[i].packet.gps_time_s, held_[i].slots)) continue;
    // Confirmed: a real re-synchronisation (or lost packets). The other held packets were
    // outliers; this one and the new packet are published, nothing of them lost.
    HeldPacket confirmed = held_[i];
    held_.erase(held_.begin() + static_cast<std::ptrdiff_t>(i));
    drop_held(held_.size(), "another time was confirmed");
    if (have_gps_reference_) {
      ROS_INFO("%s: GPS time jump of %s s to %s confirmed by the next packet", node_name_.c_str(),
               number_text(confirmed.packet.gps_time_s - gps_reference_s_).c_str(),
               time_for_message(confirmed.packet.gps_time_s).c_str());
      std::lock_guard<std::mutex> lock(mutex_);
      ++state_.gps_jumps_confirmed;
    } else {
      ROS_INFO("%s: first GPS time %s confirmed by the next packet", node_name_.c_str(),
               time_for_message(confirmed.packet.gps_time_s).c_str());
    }
    accept_gps(confirmed.packet, confirmed.arrival_s, confirmed.recorded_pc_s);
    accept_gps(packet, arrival_s, recorded_pc_s);
    return;
  }
  if (have_gps_reference_ && g <= gps_reference_s_) {
    // Backwards or repeated: never held (it cannot push the last stamp ahead); the stamp rule
    // drops what is not after the last published reading. The reference stays.
    publish_packet(packet, arrival_s, recorded_pc_s);
    return;
  }
  // Ahead of what the packets since the reference allow, or no reference yet (the first GPS
  // packet after start): hold until a later packet says whether it is real. At most
  // kMaxHeldPackets, the oldest dropped first.
  held_.push_back(HeldPacket{packet, arrival_s, recorded_pc_s, 0});
  if (held_.size() > kMaxHeldPackets) drop_held(1, "no packet confirmed it");
}

void Lemi025Driver::accept_gps(const Lemi025Packet& packet, double arrival_s, double recorded_pc_s) {
  have_gps_reference_ = true;
  gps_reference_s_ = packet.gps_time_s;
  slots_since_reference_ = 0;
  publish_packet(packet, arrival_s, recorded_pc_s);
}

void Lemi025Driver::drop_held(std::size_t count, const std::string& why) {
  for (std::size_t i = 0; i < count && !held_.empty(); ++i) {
    const Lemi025Packet& h = held_.front().packet;
    const std::string relative = have_gps_reference_ ? number_text(h.gps_time_s - gps_reference_s_) + " s after the last accepted " +
                                                           time_for_message(gps_reference_s_)
                                                     : std::string("before any accepted GPS time");
    ROS_WARN("%s: packet with GPS time %s (%s) dropped: isolated time jump, %s", node_name_.c_str(),
             time_for_message(h.gps_time_s).c_str(), relative.c_str(), why.c_str());
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++state_.packets_dropped_unconfirmed;
      state_.last_warning = time_for_message(wall_now_s()) + " packet at GPS time " + time_for_message(h.gps_time_s) +
                            " dropped: isolated time jump (" + why + ")";
    }
    held_.pop_front();
  }
}

void Lemi025Driver::release_held() {
  while (!held_.empty()) {
    ROS_INFO("%s: end of recording: the held packet at GPS time %s is published (no later packet)",
             node_name_.c_str(), time_for_message(held_.front().packet.gps_time_s).c_str());
    const HeldPacket last = held_.front();
    held_.pop_front();
    accept_gps(last.packet, last.arrival_s, last.recorded_pc_s);
  }
}

void Lemi025Driver::publish_packet(const Lemi025Packet& packet, double arrival_s, double recorded_pc_s) {
  const Lemi025DriverSettings& s = settings_;
  const bool gps_ok = packet.gps_status == 'A';
  double first_s = 0.0;
  std::string time_source;
  if (gps_ok) {
    first_s = packet.sample_time_s(0);
    pc_clock_.reset();
    time_source = "GPS";
  } else if (!s.recorded()) {
    first_s = pc_clock_.first_reading_time(arrival_s);
    time_source = "PC clock (GPS status " + std::string(1, packet.gps_status) + ")";
  } else if (std::isfinite(recorded_pc_s)) {
    first_s = pc_clock_.first_reading_time(recorded_pc_s);
    time_source = "recorded PC clock (GPS status " + std::string(1, packet.gps_status) + ")";
  } else {
    first_s = packet.sample_time_s(0);
    time_source = "instrument clock (GPS status " + std::string(1, packet.gps_status) +
                  ", the recording has no PC time)";
  }

  // Bias (compensation) field changes: an event the observatory staff must see.
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!gps_ok) ++state_.packets_without_gps;
    state_.pc_clock_steps = pc_clock_.steps();
    state_.last_pc_clock_step_s = pc_clock_.last_step_s();
    if (state_.have_packet && packet.bias_nT != state_.last.bias_nT) {
      ++state_.bias_changes;
      state_.last_bias_change_wall_s = wall_now_s();
      state_.last_bias_change = vector_text(state_.last.bias_nT) + " -> " + vector_text(packet.bias_nT) + " nT at " +
                                time_for_message(first_s);
      ROS_WARN("%s: bias (compensation) field changed: %s", node_name_.c_str(), state_.last_bias_change.c_str());
    }
    if (state_.have_packet && gps_ok != (state_.last.gps_status == 'A')) {
      if (gps_ok) {
        ROS_INFO("%s: GPS active again: stamps from GPS time", node_name_.c_str());
      } else {
        ROS_WARN("%s: GPS status %s: %s", node_name_.c_str(), gps_status_text(packet.gps_status).c_str(),
                 s.gps_required ? "readings not published (~gps_required)" : ("stamps from the " + time_source).c_str());
      }
    }
    state_.have_packet = true;
    state_.last = packet;
    state_.time_source = time_source;
  }

  // Magnetic field: one message per reading.
  std::uint64_t published = 0, invalid = 0, dropped_time = 0, dropped_gps = 0, bad_time = 0;
  const Lemi025Readings values = s.field == LemiFieldMode::kFullField ? packet.full_field_nT() : packet.variation_nT;
  const double variance = std::pow(s.noise_nT * kTeslaPerNanotesla, 2);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int k = 0; k < kLemi025ReadingsPerPacket; ++k) {
    if (s.gps_required && !gps_ok) {
      ++dropped_gps;
      continue;
    }
    const double stamp_s = gps_ok ? packet.sample_time_s(k) : first_s + k * kLemi025SamplePeriod_s;
    if (!std::isfinite(stamp_s) || stamp_s <= 0.0 || stamp_s >= 4294967295.0) {
      ++bad_time;
      continue;
    }
    const ros::Time stamp = gps_ok ? stamp_of(packet.gps_time_s, kLemi025TimeShift_s + k * kLemi025SamplePeriod_s)
                                   : ros::Time().fromSec(stamp_s);
    if (have_published_ && stamp <= last_published_) {
      ++dropped_time;
      if (!dropping_) {
        ROS_WARN("%s: reading stamped %s is not after the last published one (%s): dropping readings until the "
                 "stamps pass it",
                 node_name_.c_str(), time_for_message(stamp_s).c_str(), time_for_message(last_published_.toSec()).c_str());
        dropping_ = true;
      }
      continue;
    }
    if (dropping_) {
      ROS_INFO("%s: stamps after the last published one again from %s", node_name_.c_str(), time_for_message(stamp_s).c_str());
      dropping_ = false;
    }
    // The core's one plausibility rule (the parser has already set implausible readings to NaN).
    const auto variation = packet.variation_nT.row(k);
    const bool valid = lemi_reading_plausible(variation(0), variation(1), variation(2)) && values.row(k).allFinite();
    sensor_msgs::MagneticField message;
    message.header.stamp = stamp;
    message.header.frame_id = s.frame_id;
    message.magnetic_field.x = valid ? values(k, 0) * kTeslaPerNanotesla : nan;
    message.magnetic_field.y = valid ? values(k, 1) * kTeslaPerNanotesla : nan;
    message.magnetic_field.z = valid ? values(k, 2) * kTeslaPerNanotesla : nan;
    message.magnetic_field_covariance[0] = message.magnetic_field_covariance[4] =
        message.magnetic_field_covariance[8] = variance;
    field_publisher_.publish(message);
    have_published_ = true;
    last_published_ = stamp;
    ++published;
    if (!valid) ++invalid;
  }

  // Temperatures: one per packet, stamped like its first reading.
  if (std::isfinite(first_s) && first_s > 0.0 && first_s < 4294967295.0 && first_s > last_temperature_s_) {
    last_temperature_s_ = first_s;
    sensor_msgs::Temperature temperature;
    temperature.header.stamp = gps_ok ? stamp_of(packet.gps_time_s, kLemi025TimeShift_s) : ros::Time().fromSec(first_s);
    temperature.header.frame_id = s.frame_id;
    temperature.variance = 0.0;  // unknown
    temperature.temperature = std::isfinite(packet.sensor_temperature_C) ? packet.sensor_temperature_C : nan;
    sensor_temperature_publisher_.publish(temperature);
    temperature.temperature = std::isfinite(packet.electronics_temperature_C) ? packet.electronics_temperature_C : nan;
    electronics_temperature_publisher_.publish(temperature);
  }

  std::lock_guard<std::mutex> lock(mutex_);
  state_.readings_published += published;
  state_.readings_invalid += invalid;
  state_.readings_dropped_time += dropped_time;
  state_.readings_dropped_gps += dropped_gps;
  state_.readings_bad_time += bad_time;
  if (published > 0) state_.last_stamp_s = last_published_.toSec();
}

}  // namespace magnetometer_insitu_calibration
