// Shared by the tests of the local-event check: the busy road of the remote-reference Monte
// Carlo (benchmark/monte_carlo_remote.cpp), 600 vehicles a day 60 m from the sensors, one in ten
// parking for 2 min to 1 h, each seen by both sensors (5 m apart) with different gains.
#pragma once

#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "magnetometer_insitu_calibration/simulation/station_disturbances.hpp"

namespace magnetometer_insitu_calibration::test {

/// A simulated quiet station at 1 Hz over duration_s, without the clean field.
inline SimulationSettings quiet_station(unsigned long long seed, double duration_s) {
  SimulationSettings s;
  s.seed = seed;
  s.duration_s = duration_s;
  s.keep_clean_field = false;
  return s;
}

/// Adds the busy road's vehicles (no spikes) to `pair`; the fields each sensor saw are in the report.
inline StationDisturbanceReport add_busy_road(SimulatedPair& pair, unsigned long long seed) {
  StationDisturbanceSettings d;
  d.seed = seed;
  d.vehicles_per_day = 600;
  d.road_distance_m = 60.0;
  d.parking_probability = 0.1;
  d.small_spikes_per_day = 0;
  return add_station_disturbances(pair, d);
}

}  // namespace magnetometer_insitu_calibration::test
