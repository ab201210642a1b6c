// lemi025_driver: LEMI-025 serial port or recording -> ROS topics (see lemi025_driver.hpp).
#include "magnetometer_insitu_calibration/ros/lemi025_driver.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/ros/parameters.hpp"
#include "magnetometer_insitu_calibration/instrument/serial_port.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/Temperature.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

namespace magnetometer_insitu_calibration {

namespace {

using diagnostic_msgs::DiagnosticStatus;
using diagnostic_updater::DiagnosticStatusWrapper;

constexpr double kTeslaPerNanotesla = 1e-9;
constexpr double kBytesPerPacketSecond = static_cast<double>(kLemi025PacketSize);  // 1 packet/s live
constexpr double kBiasChangeWarningHold_s = 60.0;  // wall s a bias change stays a WARN
constexpr double kReadTimeout_s = 0.2;             // s, bounds the shutdown delay
constexpr std::size_t kMaxHeldPackets = 3;         // packets held at once awaiting confirmation

const std::vector<std::string> kKnownParameters = {
    "source", "device", "baud", "file", "rate", "checksum", "field", "frame_id", "noise_nT", "reopen_interval",
    "gps_required", "expected_packet_rate", "min_supply", "publisher_queue_size", "diagnostic_period"};

std::string gps_status_text(char status) {
  switch (status) {
    case 'A': return "A (active: GPS time)";
    case 'P': return "P (passive: no GPS fix)";
    case 'O': return "O (no GPS antenna)";
    case 'S': return "S (GPS antenna short circuit)";
    default: return std::string(1, status) + " (unknown)";
  }
}

std::string vector_text(const Eigen::Vector3d& v) {
  std::ostringstream out;
  out << v(0) << " " << v(1) << " " << v(2);
  return out.str();
}

// Stamp of base_s + offset_s, exact to the nanosecond when base_s is a whole second (GPS time):
// ros::Time::fromSec of a UNIX time in a double would be off by tens of nanoseconds.
ros::Time stamp_of(double base_s, double offset_s) {
  if (base_s == std::floor(base_s) && base_s >= 0.0 && base_s < 4294967295.0) {
    return ros::Time(static_cast<std::uint32_t>(base_s)) + ros::Duration(offset_s);
  }
  return ros::Time().fromSec(base_s + offset_s);
}

double wall_now_s() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Settings

Lemi025DriverSettings Lemi025DriverSettings::load(const ros::NodeHandle& p) {
  Lemi025DriverSettings s;
  s.source_name = param_string(p, "source", s.source_name);
  if (s.source_name == "serial") {
    s.source = Lemi025SourceKind::kSerial;
  } else if (s.source_name == "stream_file") {
    s.source = Lemi025SourceKind::kStreamFile;
  } else if (s.source_name == "lemibin") {
    s.source = Lemi025SourceKind::kLemiBin;
  } else if (s.source_name == "compact_flash") {
    s.source = Lemi025SourceKind::kCompactFlash;
  } else {
    throw ParameterError("source", "'" + s.source_name + "' is not one of serial, stream_file, lemibin, compact_flash");
  }
  s.baud = param_int(p, "baud", s.baud);
  if (s.baud != 57600 && s.baud != 19200) {
    throw ParameterError("baud", std::to_string(s.baud) + " is not a LEMI-025 rate (57600 or 19200)");
  }
  if (s.source == Lemi025SourceKind::kSerial) {
    s.device = required_string(p, "device");
  } else {
    s.file = required_string(p, "file");
  }
  s.rate = param_double(p, "rate", s.rate);
  require_non_negative("rate", s.rate, "(replay speed factor, 1 = real time, 0 = as fast as possible)");
  const std::string checksum = param_string(p, "checksum", checksum_mode_name(s.checksum));
  const std::optional<ChecksumMode> mode = parse_checksum_mode(checksum);
  if (!mode) throw ParameterError("checksum", "'" + checksum + "' is not one of none, sum8, xor8");
  s.checksum = *mode;
  const std::string field = param_string(p, "field", "full");
  if (field == "full") {
    s.field = LemiFieldMode::kFullField;
  } else if (field == "variation") {
    s.field = LemiFieldMode::kVariation;
  } else {
    throw ParameterError("field", "'" + field + "' is not one of full, variation");
  }
  s.frame_id = param_string(p, "frame_id", s.frame_id);
  if (s.frame_id.empty()) throw ParameterError("frame_id", "must not be empty");
  s.noise_nT = param_double(p, "noise_nT", s.noise_nT);
  require_non_negative("noise_nT", s.noise_nT, "nT (0 = covariance unknown)");
  s.reopen_interval_s = param_double(p, "reopen_interval", s.reopen_interval_s);
  require_positive("reopen_interval", s.reopen_interval_s, "s");
  s.gps_required = param_bool(p, "gps_required", s.gps_required);
  s.expected_packet_rate = param_double(p, "expected_packet_rate", s.expected_packet_rate);
  require_positive("expected_packet_rate", s.expected_packet_rate, "packets/s");
  s.min_supply_V = param_double(p, "min_supply", s.min_supply_V);
  require_non_negative("min_supply", s.min_supply_V, "V (0 = no check)");
  s.publisher_queue_size = param_int(p, "publisher_queue_size", s.publisher_queue_size);
  if (s.publisher_queue_size < 1) throw ParameterError("publisher_queue_size", "must be >= 1 message");
  s.diagnostic_period_s = param_double(p, "diagnostic_period", s.diagnostic_period_s);
  require_positive("diagnostic_period", s.diagnostic_period_s, "s");
  return s;
}

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
// Node

Lemi025Driver::Lemi025Driver(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : nh_(nh),
      private_nh_(private_nh),
      settings_(Lemi025DriverSettings::load(private_nh)),
      node_name_(private_nh.getNamespace()),  // the node's name; a nodelet's own name in a manager
      updater_(nh, private_nh, private_nh.getNamespace()) {
  for (const std::string& name : unknown_private_parameters(private_nh_, kKnownParameters)) {
    ROS_WARN("%s: unknown parameter ~%s is ignored (misspelt?)", node_name_.c_str(), name.c_str());
  }
  const Lemi025DriverSettings& s = settings_;
  if (s.recorded() && private_nh_.hasParam("device")) {
    ROS_WARN("%s: ~device is ignored with ~source %s (reading ~file)", node_name_.c_str(), s.source_name.c_str());
  }
  if (!s.recorded() && private_nh_.hasParam("file")) {
    ROS_WARN("%s: ~file is ignored with ~source serial (reading ~device)", node_name_.c_str());
  }

  // Open the source. A serial device that is absent is not fatal (it may be plugged in later);
  // a recording that cannot be read is.
  try {
    if (s.source == Lemi025SourceKind::kSerial || s.source == Lemi025SourceKind::kStreamFile) {
      std::unique_ptr<ByteSource> bytes;
      if (s.source == Lemi025SourceKind::kSerial) {
        auto serial = std::make_unique<SerialPortSource>(s.device, s.baud);
        if (!serial->ok()) {
          ROS_WARN("%s: %s not open yet (%s): retrying every %g s", node_name_.c_str(), s.device.c_str(),
                   serial->last_error().c_str(), s.reopen_interval_s);
        }
        bytes = std::move(serial);
      } else {
        FileByteSourceOptions options;
        options.bytes_per_second = s.rate * kBytesPerPacketSecond;
        bytes = std::make_unique<FileByteSource>(s.file, options);
      }
      StreamPacketSourceOptions options;
      options.parser.checksum = s.checksum;
      options.reopen_interval_s = s.reopen_interval_s;
      source_ = std::make_unique<StreamPacketSource>(std::move(bytes), options);
    } else if (s.source == Lemi025SourceKind::kLemiBin) {
      LemiReadOptions options;
      options.checksum = s.checksum;
      auto lemibin = std::make_unique<LemiBinPacketSource>(s.file, options);
      lemibin_ = lemibin.get();
      source_ = std::move(lemibin);
    } else {
      source_ = std::make_unique<CompactFlashPacketSource>(s.file);
    }
  } catch (const InputError& e) {
    if (e.where() == "baud") throw ParameterError("baud", e.problem());
    throw ParameterError(s.recorded() ? "file" : "device", e.what());
  } catch (const std::exception& e) {  // e.g. std::filesystem errors of the file readers
    throw ParameterError(s.recorded() ? "file" : "device", e.what());
  }
  description_ = source_->describe();

  const auto queue = static_cast<std::uint32_t>(s.publisher_queue_size);
  field_publisher_ = nh_.advertise<sensor_msgs::MagneticField>("magnetic_field", queue);
  sensor_temperature_publisher_ = nh_.advertise<sensor_msgs::Temperature>("temperature/sensor", queue);
  electronics_temperature_publisher_ = nh_.advertise<sensor_msgs::Temperature>("temperature/electronics", queue);

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
  diagnostic_timer_ = nh_.createTimer(ros::Duration(s.diagnostic_period_s),
                                      [this](const ros::TimerEvent&) { updater_.force_update(); });

  ROS_INFO("%s: %s -> %s in frame '%s' (%s field, noise %g nT%s)", node_name_.c_str(), description_.c_str(),
           nh_.resolveName("magnetic_field").c_str(), s.frame_id.c_str(),
           s.field == LemiFieldMode::kFullField ? "full" : "variation", s.noise_nT,
           s.recorded() ? (", replay rate " + number_text(s.rate)).c_str() : "");
  reader_ = std::thread([this] { run(); });
}

Lemi025Driver::~Lemi025Driver() {
  {
    std::lock_guard<std::mutex> lock(stop_mutex_);
    stopping_ = true;
  }
  stop_cv_.notify_all();
  if (reader_.joinable()) reader_.join();
}

bool Lemi025Driver::pace(std::uint64_t index) {
  using Clock = std::chrono::steady_clock;
  if (index == 0) pace_start_ = Clock::now();
  const auto due = pace_start_ + std::chrono::duration_cast<Clock::duration>(
                               std::chrono::duration<double>(static_cast<double>(index) / settings_.rate));
  std::unique_lock<std::mutex> lock(stop_mutex_);
  return !stop_cv_.wait_until(lock, due, [this] { return stopping_.load(); });
}

void Lemi025Driver::run() {
  bool end_reported = false;
  while (!stopping_ && ros::ok()) {
    const std::optional<Lemi025Packet> packet = source_->next(kReadTimeout_s);
    const double arrival_s = ros::Time::now().toSec();
    std::string last_warning;
    for (const std::string& warning : source_->take_warnings()) {
      if (warning.rfind("reconnected", 0) == 0) {
        ROS_INFO("%s: %s", node_name_.c_str(), warning.c_str());
      } else {
        ROS_WARN("%s: %s", node_name_.c_str(), warning.c_str());
      }
      if (warning.rfind("disconnected", 0) == 0) pc_clock_.reset();
      last_warning = warning;
    }
    if (packet) {
      double recorded_pc_s = std::numeric_limits<double>::quiet_NaN();
      if (lemibin_ && packet_index_ < lemibin_->pc_times_s().size()) recorded_pc_s = lemibin_->pc_times_s()[packet_index_];
      if (settings_.recorded() && settings_.source != Lemi025SourceKind::kStreamFile && settings_.rate > 0.0) {
        if (!pace(packet_index_)) break;
      }
      ++packet_index_;
      handle(*packet, arrival_s, recorded_pc_s);
    }
    const bool at_end = source_->at_end();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      state_.stats = source_->stats();
      state_.connected = source_->connected();
      state_.at_end = at_end;
      if (!last_warning.empty()) state_.last_warning = time_for_message(wall_now_s()) + " " + last_warning;
    }
    if (at_end && !packet) {
      release_held();
      if (!end_reported) {
        ROS_INFO("%s: end of recording %s after %llu packets", node_name_.c_str(), settings_.file.c_str(),
                 static_cast<unsigned long long>(packet_index_));
        end_reported = true;
      }
      std::unique_lock<std::mutex> lock(stop_mutex_);
      stop_cv_.wait(lock, [this] { return stopping_.load(); });
    }
  }
}

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

// ---------------------------------------------------------------------------------------------
// Diagnostics

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
    status.mergeSummary(DiagnosticStatus::ERROR, "disconnected: reopening every " + number_text(settings_.reopen_interval_s) +
                                                     " s");
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
