// The family of disturbed stations: see disturbance_classes.hpp.
#include "magnetometer_insitu_calibration/simulation/disturbance_classes.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <algorithm>
#include <cmath>
#include <random>

namespace magnetometer_insitu_calibration {

const std::vector<std::string>& disturbance_class_names() {
  static const std::vector<std::string> names = {"quiet",       "passing_few", "passing_busy", "slow_hourly",
                                                 "parked_long", "busy_road",   "weak_mixed",   "strong_mixed",
                                                 "alike_mixed", "heater",      "pier_tilt"};
  return names;
}

namespace {

/// The base station every class shares (disturbance_classes.hpp), its fields set in `c`.
void base_station(std::uint64_t seed, double days, DisturbanceClassSettings& c) {
  std::mt19937_64 rng(seed * 7919 + 17);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  SimulationSettings& s = c.simulation;
  s.variation_rms_nT = 5.0 * std::sqrt(days);  // nT over the record
  s.variation_z_ratio = 0.2;
  s.spikes_per_day = 20;
  s.gap_count = static_cast<int>(2 * days);
  s.gap_length_s = 600.0;
  StationDisturbanceSettings& d = c.station;
  d.seed = seed;
  d.vehicles_per_day = 0.0;
  d.small_spikes_per_day = 50;
  d.steps = 0;
  UnmodelledDisturbanceSettings& u = c.unmodelled;
  u.seed = seed;
  u.tilt_walk_nT_per_sqrt_day = 0.27;
  const double heater_nT = 0.02 + 0.03 * uniform(rng);
  const Eigen::Vector3d direction(uniform(rng) - 0.5, uniform(rng) - 0.5, uniform(rng) - 0.5);
  u.heater_nT = heater_nT * direction.normalized();
  u.heater_period_s = 1800.0;
  u.test_corner_hz = 0.5;
  u.test_delay_s = 0.2;
}

/// Vehicles: per hour, road distance (m), share parking.
void traffic(StationDisturbanceSettings& d, double per_hour, double road_m, double parking) {
  d.vehicles_per_day = 24.0 * per_hour;
  d.road_distance_m = road_m;
  d.parking_probability = parking;
}

}  // namespace

void apply_disturbance_class(const std::string& name, std::uint64_t seed, double days, DisturbanceClassSettings& c) {
  base_station(seed, days, c);
  StationDisturbanceSettings& d = c.station;
  std::mt19937_64 rng(seed * 104723 + 29);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  if (name == "quiet") {
  } else if (name == "passing_few") {
    traffic(d, 3.0, 80.0, 0.0);
  } else if (name == "passing_busy") {
    traffic(d, 30.0, 80.0, 0.0);
  } else if (name == "slow_hourly") {
    traffic(d, 1.0, 80.0, 0.0);
    d.speed_min_m_per_s = 0.3;
    d.speed_max_m_per_s = 1.0;
  } else if (name == "parked_long") {
    traffic(d, 1.0, 80.0, 1.0);
    d.parking_min_s = 600.0;
    d.parking_max_s = 3600.0;
  } else if (name == "busy_road") {
    traffic(d, 25.0, 60.0, 0.1);
  } else if (name == "weak_mixed") {
    traffic(d, 10.0, 150.0, 0.2);
  } else if (name == "strong_mixed" || name == "alike_mixed") {
    traffic(d, 10.0, 45.0, 0.2);
    if (name == "alike_mixed") d.test_sensor_offset_m = Eigen::Vector3d::Zero();
  } else if (name == "heater") {
    const double heater_nT = 0.1 + 0.2 * uniform(rng);
    c.unmodelled.heater_nT = heater_nT * c.unmodelled.heater_nT.normalized();
    c.unmodelled.heater_period_s = 600.0 * std::pow(6.0, uniform(rng));  // 10-60 min
  } else if (name == "pier_tilt") {
    c.unmodelled.tilt_walk_nT_per_sqrt_day = 2.0;
  } else {
    std::string known;
    for (const std::string& n : disturbance_class_names()) known += (known.empty() ? "" : ", ") + n;
    throw InputError("--disturbance-class", "unknown class '" + name + "' (one of " + known + ")");
  }
}

DisturbanceClassSettings disturbance_class(const std::string& name, std::uint64_t seed, double days) {
  DisturbanceClassSettings c;
  c.simulation.seed = c.station.seed = c.unmodelled.seed = seed;
  c.simulation.duration_s = days * 86400.0;
  c.simulation.keep_clean_field = false;
  apply_disturbance_class(name, seed, days, c);
  return c;
}

SimulatedPair simulate_disturbance_class(const DisturbanceClassSettings& c) {
  SimulatedPair pair = simulate_pair(c.simulation);
  add_station_disturbances(pair, c.station);
  add_unmodelled_disturbances(pair, c.unmodelled);
  return pair;
}

}  // namespace magnetometer_insitu_calibration
