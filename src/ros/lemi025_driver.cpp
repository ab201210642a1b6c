// lemi025_driver: LEMI-025 serial port or recording -> ROS topics (see lemi025_driver.hpp).
// This file: the parameters, construction (source, publishers, diagnostics, reading thread) and
// shutdown. The rest of the class: lemi025_driver_port.cpp (opening the source, the reading
// thread, disconnection and reconnection), lemi025_driver_timing.cpp (GPS and PC clock stamps,
// held packets, publishing), lemi025_driver_diagnostics.cpp (the /diagnostics tasks).
#include "magnetometer_insitu_calibration/ros/lemi025_driver.hpp"

#include "magnetometer_insitu_calibration/ros/parameters.hpp"

#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/Temperature.h>

namespace magnetometer_insitu_calibration {

namespace {

const std::vector<std::string> kDriverParameters = {
    "source", "device", "baud", "file", "rate", "checksum", "field", "frame_id", "noise_nT", "reopen_interval",
    "gps_required", "expected_packet_rate", "min_supply", "publisher_queue_size", "diagnostic_period",
    "wait_for_subscribers"};

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
  s.wait_for_subscribers = param_int(p, "wait_for_subscribers", s.wait_for_subscribers);
  if (s.wait_for_subscribers < 0) throw ParameterError("wait_for_subscribers", "must be >= 0 subscribers");
  s.diagnostic_period_s = param_double(p, "diagnostic_period", s.diagnostic_period_s);
  require_positive("diagnostic_period", s.diagnostic_period_s, "s");
  return s;
}

// ---------------------------------------------------------------------------------------------
// Node

Lemi025Driver::Lemi025Driver(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : nh_(nh),
      private_nh_(private_nh),
      settings_(Lemi025DriverSettings::load(private_nh)),
      node_name_(private_nh.getNamespace()),  // the node's name; a nodelet's own name in a manager
      updater_(nh, private_nh, private_nh.getNamespace()) {
  for (const std::string& name : unknown_private_parameters(private_nh_, kDriverParameters)) {
    ROS_WARN("%s: unknown parameter ~%s is ignored (misspelt?)", node_name_.c_str(), name.c_str());
  }
  const Lemi025DriverSettings& s = settings_;
  if (s.recorded() && private_nh_.hasParam("device")) {
    ROS_WARN("%s: ~device is ignored with ~source %s (reading ~file)", node_name_.c_str(), s.source_name.c_str());
  }
  if (!s.recorded() && private_nh_.hasParam("file")) {
    ROS_WARN("%s: ~file is ignored with ~source serial (reading ~device)", node_name_.c_str());
  }

  open_source();
  description_ = source_->describe();

  const auto queue = static_cast<std::uint32_t>(s.publisher_queue_size);
  field_publisher_ = nh_.advertise<sensor_msgs::MagneticField>("magnetic_field", queue);
  sensor_temperature_publisher_ = nh_.advertise<sensor_msgs::Temperature>("temperature/sensor", queue);
  electronics_temperature_publisher_ = nh_.advertise<sensor_msgs::Temperature>("temperature/electronics", queue);

  setup_diagnostics();

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

}  // namespace magnetometer_insitu_calibration
