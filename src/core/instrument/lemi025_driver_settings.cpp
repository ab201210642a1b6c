// The LEMI-025 driver's settings, each declared once (lemi025_driver_settings.hpp).
#include "magnetometer_insitu_calibration/instrument/lemi025_driver_settings.hpp"

namespace magnetometer_insitu_calibration {

namespace {

using K = SettingKind;
constexpr const char* kNone = "";

SettingDeclarations source() {
  return setting_group("Source", {
      choice_setting("source", "source", kNone, {"serial", "stream_file", "lemibin", "compact_flash"}, "serial",
                     "where packets come from: the RS-232 port (or a pty), a byte-stream capture, a LemiBin file, a "
                     "compact-flash image"),
      text_setting(K::kPath, "device", "device", kNone, "", "serial device or a link to it (source serial)")
          .noted("required for serial"),
      integer_setting("baud", "baud", kNone, "bit/s", 57600, between(19200, 57600), "57600 or 19200; 8N1"),
      text_setting(K::kPath, "file", "file", kNone, "", "the recording (source stream_file, lemibin, compact_flash)")
          .noted("required for a recording"),
      number_setting("rate", "rate", kNone, "-", 1.0, at_least(0),
                     "replay speed of a recording: 1 = real time, 0 = as fast as possible"),
      choice_setting("checksum", "checksum", kNone, {"none", "sum8", "xor8"}, "none",
                     "the packet's last byte: none (the vendor does not publish it), sum8 or xor8"),
      number_setting("reopen_interval", "reopen_interval", kNone, "s (wall)", 1.0, above(0),
                     "between attempts to reopen a disconnected serial port"),
  });
}

SettingDeclarations output() {
  return setting_group("Output", {
      choice_setting("field", "field", kNone, {"full", "variation"}, "full",
                     "full: bias field + variation (the field in the sensor frame); variation: relative to the bias"),
      text_setting(K::kText, "frame_id", "frame_id", kNone, "lemi025", "header.frame_id of every message"),
      number_setting("noise_nT", "noise_nT", kNone, "nT", 0.02, at_least(0),
                     "per-reading noise, the covariance's diagonal; 0 = covariance unknown"),
      flag_setting("gps_required", "gps_required", kNone, false,
                   "while GPS is not 'A': publish with PC-clock stamps (false) or not at all (true)"),
      integer_setting("publisher_queue_size", "publisher_queue_size", kNone, "messages", 1000, at_least(1),
                      "each publisher's queue"),
      integer_setting("wait_for_subscribers", "wait_for_subscribers", kNone, "subscribers", 0, at_least(0),
                      "a recording starts when magnetic_field has this many subscribers; 0 = at once"),
  });
}

SettingDeclarations diagnostics() {
  return setting_group("Diagnostics", {
      number_setting("expected_packet_rate", "expected_packet_rate", kNone, "packets/s", 1.0, above(0),
                     "packets expected per second from the serial port (1 = the instrument)"),
      number_setting("min_supply", "min_supply", kNone, "V", 0.0, at_least(0),
                     "warn when the supply voltage is below it; 0 = no check"),
      number_setting("diagnostic_period", "diagnostic_period", kNone, "s (wall)", 1.0, above(0),
                     "between /diagnostics"),
  });
}

}  // namespace

const SettingDeclarations& lemi025_driver_setting_declarations() {
  static const SettingDeclarations declarations = joined_settings({source(), output(), diagnostics()});
  return declarations;
}

}  // namespace magnetometer_insitu_calibration
