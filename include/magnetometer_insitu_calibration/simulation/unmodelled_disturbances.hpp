// Disturbances that reach the TEST instrument only and that the estimators do not model, added
// to a simulated pair (simulator.hpp) after simulate_pair() and, if used,
// add_station_disturbances(). Without them the package's own simulator is an easy case: the
// robust default must also be judged on records with them.
//
//  - Response mismatch: the test instrument sees everything through a one-pole low-pass filter
//    H(f) = 1 / (1 + i f / corner) and a pure delay, H(f) e^{-2 pi i f delay}; the reference is
//    unfiltered. Applied to the whole test record (field, noise, earlier disturbances) except
//    the simulator's one-sample spikes (instrument glitches after the filter, pair.spikes) and
//    gaps (filled by straight lines for the filter, NaN again afterwards). In the frequency
//    domain over the whole record after removing the line through the first and last sample;
//    the line itself goes through the filter's low-frequency limit, a delay of
//    delay + 1 / (2 pi corner).
//  - Pier tilt random walk: the test pier tilts about the two horizontal reference axes (x
//    north, y east) by angles theta(t) that are independent Gaussian random walks (1/f^2
//    spectrum), theta(0) = 0. The test reads B (I + [theta]x) n(t) instead of B n(t): the added
//    field is B [theta]x n(t), with B the reference reading (the main field where it is NaN).
//    The walk's size is given as the field change it causes, tilt_walk_nT_per_sqrt_day:
//    standard deviation of |B| theta per horizontal axis after one day (|B| the magnitude of
//    the mean reference reading), growing as sqrt(t) (0.27 nT/sqrt(day) gives 0.6 nT after
//    5 days).
//  - Heater cycling: a thermostat switches a heater in the test sensor's housing on and off;
//    its current adds a constant field (heater_nT, test frame) while on, reached and left with
//    the time constant heater_time_constant_s. Cycle lengths are uniform in
//    heater_period_s (1 +- heater_period_jitter), on for heater_duty of each cycle.
#pragma once

#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <Eigen/Core>

#include <cstdint>

namespace magnetometer_insitu_calibration {

struct UnmodelledDisturbanceSettings {
  std::uint64_t seed = 1;
  // Response mismatch of the test instrument.
  double test_corner_hz = 0.0;      ///< one-pole low-pass corner, Hz; 0: no filter
  double test_delay_s = 0.0;        ///< extra pure delay of the test, s (may be negative)
  // Pier tilt random walk of the test sensor.
  double tilt_walk_nT_per_sqrt_day = 0.0;  ///< nT after one day (1 sigma per horizontal axis)
  // Heater cycling in the test sensor.
  Eigen::Vector3d heater_nT = Eigen::Vector3d::Zero();  ///< field while on, test frame, nT
  double heater_period_s = 1800.0;  ///< mean cycle length, s
  double heater_period_jitter = 0.2;  ///< cycle lengths uniform in period (1 +- jitter), [0, 0.9]
  double heater_duty = 0.4;         ///< share of a cycle the heater is on, (0, 1)
  double heater_time_constant_s = 60.0;  ///< rise and fall time constant, s (> 0)

  void validate() const;  ///< throws InputError naming the field
};

struct UnmodelledDisturbanceReport {
  /// Per sample, the field added to the test by the tilt walk and by the heater (test frame,
  /// nT, N x 3 each; NaN samples of the test stay NaN in the record but not here).
  Readings tilt_added_nT, heater_added_nT;
  Eigen::Vector2d tilt_end_rad = Eigen::Vector2d::Zero();  ///< theta about x, y at the end
  std::size_t heater_cycles = 0;
};

/// Adds the disturbances above to pair.test in place, in this order: tilt walk, heater, then
/// the response mismatch over everything. Deterministic for a given seed.
UnmodelledDisturbanceReport add_unmodelled_disturbances(SimulatedPair& pair,
                                                        const UnmodelledDisturbanceSettings& settings);

/// The response mismatch alone on one record (N x 3, regular period dt s; NaN runs filled by
/// straight lines for the filter and NaN again afterwards): one-pole low-pass at corner_hz
/// (0: none) and a delay of delay_s.
void apply_test_response(Readings& values, double sample_period_s, double corner_hz, double delay_s);

}  // namespace magnetometer_insitu_calibration
