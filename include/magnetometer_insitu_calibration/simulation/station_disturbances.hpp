// Local disturbances of a disturbed station, added to a simulated pair (simulator.hpp) after
// simulate_pair(): vehicles on a nearby road (moving and parked magnetic dipoles, seen by the two
// sensors with different gains and directions), small spikes from a temperature regulator that
// a despiker does not catch, and baseline steps.
//
// Vehicles. A vehicle is a magnetic dipole m (A m^2, random direction, log-uniform magnitude)
// on a straight horizontal road at horizontal distance road_distance_m from the reference
// sensor, moving at speed v; with probability parking_probability it stops at the closest
// point for a log-uniform dwell time. The field of a dipole at offset r (m) is
//   b = mu0 / (4 pi) (3 (m . r_hat) r_hat - m) / |r|^3        (T; x 1e9 for nT),
// evaluated at the reference sensor (origin) and at the test sensor (test_sensor_offset_m): the
// 1/r^3 fall-off and the change of direction give the two instruments different gains and
// directions, which is what biases a least-squares fit. Frames: reference x north, y east,
// z down, metres; the reference reads b(t) (reference frame), the test reads b_test(t) n(t)
// (its own frame, through the same calibration matrix as the field).
#pragma once

#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace magnetometer_insitu_calibration {

struct StationDisturbanceSettings {
  std::uint64_t seed = 1;
  // Vehicles.
  double vehicles_per_day = 0.0;
  double road_distance_m = 40.0;            ///< horizontal distance road - reference sensor, m
  double road_azimuth_deg = 30.0;           ///< direction of the road from north, degrees
  double road_height_m = -1.0;              ///< dipole height (z down: negative = above the sensors), m
  Eigen::Vector3d test_sensor_offset_m{3.0, 4.0, 0.0};  ///< test sensor from the reference, m
  double moment_min_Am2 = 50.0;             ///< dipole moment range, A m^2 (log-uniform)
  double moment_max_Am2 = 1000.0;
  double speed_min_m_per_s = 3.0;           ///< speed range, m/s (uniform)
  double speed_max_m_per_s = 15.0;
  double parking_probability = 0.1;         ///< share of vehicles that stop by the road
  double parking_min_s = 120.0;             ///< dwell time range, s (log-uniform)
  double parking_max_s = 3600.0;
  // Small spikes (temperature regulator): runs of 1..3 samples in one random component.
  double small_spikes_per_day = 0.0;
  double small_spike_min_nT = 0.1;          ///< amplitude range, nT (log-uniform, random sign)
  double small_spike_max_nT = 1.0;
  SimulatedInstrument small_spike_instrument = SimulatedInstrument::kEither;
  // Baseline steps: a constant added from a random sample on, one component of one instrument.
  int steps = 0;
  double step_min_nT = 0.2;                 ///< amplitude range, nT (log-uniform, random sign)
  double step_max_nT = 2.0;
  SimulatedInstrument step_instrument = SimulatedInstrument::kEither;

  void validate() const;  ///< throws InputError naming the field
};

struct StationDisturbanceReport {
  std::size_t vehicles = 0, parked = 0, small_spikes = 0, steps = 0;
  /// Largest |field| of any vehicle at the reference / test sensor, nT.
  double max_vehicle_reference_nT = 0.0, max_vehicle_test_nT = 0.0;
  /// Per sample, the disturbance added (reference frame at the reference, test frame at the
  /// test), nT, N x 3 each: the truth a screen should find.
  Readings reference_added_nT, test_added_nT;
};

/// Adds the disturbances to pair.reference / pair.test in place (NaN samples stay NaN).
/// Deterministic for a given seed. Uses pair.n_at(t) for the test sensor's frame.
StationDisturbanceReport add_station_disturbances(SimulatedPair& pair, const StationDisturbanceSettings& settings);

}  // namespace magnetometer_insitu_calibration
