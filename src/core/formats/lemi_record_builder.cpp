// LEMI-025 packets to a 10 Hz VectorRecord (used by every LEMI reader).
#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"

#include <cmath>
#include <sstream>
#include <utility>

namespace magnetometer_insitu_calibration {

VectorRecord lemi025_packets_to_record(const std::vector<Lemi025Packet>& packets,
                                       const LemiReadOptions& options,
                                       std::vector<std::string>* warnings) {
  VectorRecord record;
  const std::size_t capacity = packets.size() * kLemi025ReadingsPerPacket;
  record.time_s.reserve(capacity);
  Readings values(static_cast<Eigen::Index>(capacity), 3);
  Eigen::Index row = 0;
  // The packet's temperatures (one per second), repeated for each of its ten readings.
  AuxiliaryChannel sensor{"sensor_temperature", "T_sensor (LEMI-025 packet)", "degC", {}};
  AuxiliaryChannel electronics{"electronics_temperature", "T_electronics (LEMI-025 packet)", "degC", {}};
  sensor.values.reserve(capacity);
  electronics.values.reserve(capacity);
  std::size_t bias_changes = 0;
  std::size_t gps_not_active = 0;
  const double extra_shift_s = options.time_shift_s - kLemi025TimeShift_s;
  for (std::size_t i = 0; i < packets.size(); ++i) {
    const Lemi025Packet& p = packets[i];
    if (i > 0 && p.bias_nT != packets[i - 1].bias_nT) ++bias_changes;
    if (p.gps_status != 'A') ++gps_not_active;
    const Lemi025Readings v =
        options.field == LemiFieldMode::kFullField ? p.full_field_nT() : p.variation_nT;
    int dropped = 0;
    for (int k = 0; k < kLemi025ReadingsPerPacket; ++k) {
      const double t = p.sample_time_s(k) + extra_shift_s;
      if (!std::isfinite(t) || (!record.time_s.empty() && !(t > record.time_s.back()))) {
        ++dropped;
        continue;
      }
      record.time_s.push_back(t);
      values.row(row++) = v.row(k);
      sensor.values.push_back(p.sensor_temperature_C);
      electronics.values.push_back(p.electronics_temperature_C);
    }
    if (dropped > 0 && warnings != nullptr) {
      std::ostringstream message;
      message.precision(15);
      message << "packet at GPS time " << p.gps_time_s << " s: " << dropped
              << " of its readings dropped, not after the previous reading";
      warnings->push_back(message.str());
    }
  }
  record.values_nT = values.topRows(row);
  if (!packets.empty()) {
    record.auxiliary.push_back(std::move(sensor));
    record.auxiliary.push_back(std::move(electronics));
  }
  if (!packets.empty()) {
    record.header["instrument"] = lemi_model_name(packets.front().model);
    record.header["station_number"] = std::to_string(packets.front().station);
  }
  record.header["values"] = options.field == LemiFieldMode::kFullField
                                ? "full field (bias + variation), nT"
                                : "variation relative to the bias field, nT";
  std::ostringstream shift;
  shift << options.time_shift_s;
  record.header["time_shift_s"] = shift.str();
  record.header["bias_changes"] = std::to_string(bias_changes);
  record.header["gps_not_active"] = std::to_string(gps_not_active);
  return record;
}

}  // namespace magnetometer_insitu_calibration
