// lemi025_driver: LEMI-025 serial port or recording -> ROS topics (see lemi025_driver.hpp).
// This file: the parameters, construction (source, publishers, diagnostics, reading thread) and
// shutdown. The rest of the class: lemi025_driver_port.cpp (opening the source, the reading
// thread, disconnection and reconnection), lemi025_driver_timing.cpp (GPS and PC clock stamps,
// held packets, publishing), lemi025_driver_diagnostics.cpp (the /diagnostics tasks).
#include "magnetometer_insitu_calibration/ros/lemi025_driver.hpp"

#include "magnetometer_insitu_calibration/instrument/lemi025_driver_settings.hpp"
#include "magnetometer_insitu_calibration/ros/parameters.hpp"

#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/Temperature.h>

namespace magnetometer_insitu_calibration {

namespace {

using D = Lemi025DriverSettings;

}  // namespace

/// The declared parameters bound to the driver's settings (instrument/lemi025_driver_settings.hpp).
const SettingBindings<D>& Lemi025DriverSettings::bindings() {
  static const SettingBindings<D> bindings = [] {
    SettingBindings<D> b(lemi025_driver_setting_declarations());
    b.bind_with(
        "source",
        [](D& d, const SettingValue& v) {
          d.source_name = std::get<std::string>(v);
          d.source = d.source_name == "stream_file"     ? Lemi025SourceKind::kStreamFile
                     : d.source_name == "lemibin"       ? Lemi025SourceKind::kLemiBin
                     : d.source_name == "compact_flash" ? Lemi025SourceKind::kCompactFlash
                                                        : Lemi025SourceKind::kSerial;
        },
        [](const D& d) { return SettingValue(d.source_name); });
    b.bind("device", [](D& d) -> std::string& { return d.device; })
        .bind("baud", [](D& d) -> int& { return d.baud; })
        .bind("file", [](D& d) -> std::string& { return d.file; })
        .bind("rate", [](D& d) -> double& { return d.rate; });
    b.bind_with(
        "checksum", [](D& d, const SettingValue& v) { d.checksum = *parse_checksum_mode(std::get<std::string>(v)); },
        [](const D& d) { return SettingValue(checksum_mode_name(d.checksum)); });
    b.bind("reopen_interval", [](D& d) -> double& { return d.reopen_interval_s; });
    b.bind_with(
        "field",
        [](D& d, const SettingValue& v) {
          d.field = std::get<std::string>(v) == "variation" ? LemiFieldMode::kVariation : LemiFieldMode::kFullField;
        },
        [](const D& d) { return SettingValue(std::string(d.field == LemiFieldMode::kVariation ? "variation" : "full")); });
    b.bind("frame_id", [](D& d) -> std::string& { return d.frame_id; })
        .bind("noise_nT", [](D& d) -> double& { return d.noise_nT; })
        .bind("gps_required", [](D& d) -> bool& { return d.gps_required; })
        .bind("publisher_queue_size", [](D& d) -> int& { return d.publisher_queue_size; })
        .bind("wait_for_subscribers", [](D& d) -> int& { return d.wait_for_subscribers; })
        .bind("expected_packet_rate", [](D& d) -> double& { return d.expected_packet_rate; })
        .bind("min_supply", [](D& d) -> double& { return d.min_supply_V; })
        .bind("diagnostic_period", [](D& d) -> double& { return d.diagnostic_period_s; });
    return b;
  }();
  return bindings;
}


// ---------------------------------------------------------------------------------------------
// Settings

Lemi025DriverSettings Lemi025DriverSettings::load(const ros::NodeHandle& p) {
  Lemi025DriverSettings s;
  load_declared(p, bindings(), s);
  if (s.baud != 57600 && s.baud != 19200) {
    throw ParameterError("baud", std::to_string(s.baud) + " is not a LEMI-025 rate (57600 or 19200)");
  }
  // The port or the recording, as the source needs.
  const std::string source_path = s.source == Lemi025SourceKind::kSerial ? "device" : "file";
  if ((source_path == "device" ? s.device : s.file).empty()) {
    throw ParameterError(source_path, p.hasParam(source_path) ? "must not be empty" : "is required and not set");
  }
  if (s.frame_id.empty()) throw ParameterError("frame_id", "must not be empty");
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
  for (const std::string& name : unknown_private_parameters(private_nh_, declared_parameters(lemi025_driver_setting_declarations()))) {
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
