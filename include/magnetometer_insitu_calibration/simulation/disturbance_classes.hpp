// A family of disturbed stations, by class, for judging the pair's checks and intervals on more
// than one road (simulate_records --disturbance-class NAME, benchmark/monte_carlo_family).
//
// Every class shares one base station: 1 Hz, weak in-band signal (5 nT rms per sqrt(day) on x and
// y, Z a fifth of it), 20 large spikes and 50 small ones a day, two 10-minute gaps a day, a pier
// tilt walk of the test (0.27 nT/sqrt(day)), a small heater in the test (0.02-0.05 nT, 30-minute
// cycles) and the test behind a 0.5 Hz low-pass with a 0.2 s delay. The classes add to it:
//
//   quiet          nothing
//   passing_few    3 vehicles an hour passing 80 m away (10-50 s each), seen differently
//   passing_busy   30 vehicles an hour passing 80 m away
//   slow_hourly    1 vehicle an hour crawling past at 0.3-1 m/s (3-9 minutes in the band)
//   parked_long    1 vehicle an hour stopping 10-60 minutes
//   busy_road      25 vehicles an hour at 60 m, one in ten parking 2 minutes to 1 hour
//   weak_mixed     10 vehicles an hour at 150 m (about the instruments' noise), a fifth parking
//   strong_mixed   10 vehicles an hour at 45 m (about ten times the noise), a fifth parking
//   alike_mixed    strong_mixed with both sensors at one place: the vehicles seen alike
//   heater         the test's heater 0.1-0.3 nT (ten times the noise), 10-60 minute cycles
//   pier_tilt      the test pier's tilt walk 2 nT/sqrt(day)
//
// "Seen differently": the test sensor 5 m from the reference (3, 4, 0 m), so that the two see
// each vehicle's dipole with different gains and directions. Dipole moments 50-1000 A m^2.
#pragma once

#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "magnetometer_insitu_calibration/simulation/station_disturbances.hpp"
#include "magnetometer_insitu_calibration/simulation/unmodelled_disturbances.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

struct DisturbanceClassSettings {
  SimulationSettings simulation;
  StationDisturbanceSettings station;
  UnmodelledDisturbanceSettings unmodelled;
};

/// The names of the classes, in the order above.
const std::vector<std::string>& disturbance_class_names();

/// Sets the fields class `name` defines (the base station's and the class's own) in `c`, the
/// others kept; `seed` draws the heater, `days` sets the gaps' count and the variations' rms.
/// Throws InputError ("--disturbance-class") for an unknown name.
void apply_disturbance_class(const std::string& name, std::uint64_t seed, double days, DisturbanceClassSettings& c);

/// The settings of class `name` for one seed and `days` of record at 1 Hz (the simulator's
/// defaults where the class sets nothing; no clean field kept).
DisturbanceClassSettings disturbance_class(const std::string& name, std::uint64_t seed, double days);

/// The pair of class settings `c`: simulate_pair, the station's disturbances, then what reaches
/// the test alone.
SimulatedPair simulate_disturbance_class(const DisturbanceClassSettings& c);

}  // namespace magnetometer_insitu_calibration
