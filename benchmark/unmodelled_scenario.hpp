// The simulated stations of the Monte Carlo programs that run the estimators on records with
// what they do not model (monte_carlo_unmodelled, monte_carlo_window_agreement): the quiet
// station (simulator defaults), the disturbed one (weak vertical, traffic seen with different
// gains and directions, spikes, gaps, a tilt walk of the test pier, heater cycling, a response
// mismatch) and the quiet one behind a filter and a delay. Environment knobs (MC_*) change one
// disturbance at a time.
#pragma once

#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "magnetometer_insitu_calibration/simulation/station_disturbances.hpp"
#include "magnetometer_insitu_calibration/simulation/unmodelled_disturbances.hpp"

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <random>
#include <string>

namespace monte_carlo {

namespace mic = magnetometer_insitu_calibration;

/// Environment override of a scenario number (for exploring which disturbance does what).
inline double knob(const char* name, double value) {
  const char* text = std::getenv(name);
  return text != nullptr ? std::atof(text) : value;
}

/// The station of one seed. kind "disturbed": weak vertical, traffic, spikes, gaps, pier tilt
/// walk, heater, response mismatch; "quiet": simulator defaults, nothing else (gaps only when
/// MC_GAPS asks for them).
inline void scenario(const std::string& kind, std::uint64_t seed, double days, mic::SimulationSettings& s,
              mic::StationDisturbanceSettings& d, mic::UnmodelledDisturbanceSettings& u) {
  std::mt19937_64 rng(seed * 7919 + 17);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  s = mic::SimulationSettings{};
  s.seed = seed;
  s.duration_s = days * 86400.0;
  s.keep_clean_field = false;
  d = mic::StationDisturbanceSettings{};
  d.seed = seed;
  u = mic::UnmodelledDisturbanceSettings{};
  u.seed = seed;
  // Instrument noise (simulator defaults: white 0.01 nT per sample, 1/f 0.005 nT/sqrt(Hz) at 1 Hz).
  s.reference_white_nT = knob("MC_REF_WHITE", s.reference_white_nT);
  s.test_white_nT = knob("MC_TEST_WHITE", s.test_white_nT);
  s.reference_pink_nT_per_sqrt_hz = knob("MC_REF_PINK", s.reference_pink_nT_per_sqrt_hz);
  s.test_pink_nT_per_sqrt_hz = knob("MC_TEST_PINK", s.test_pink_nT_per_sqrt_hz);
  if (kind == "quiet") {  // MC_GAPS / MC_GAP_S: gaps per day and their length (none by default)
    s.gap_count = static_cast<int>(knob("MC_GAPS", 0) * days);
    s.gap_length_s = knob("MC_GAP_S", 600.0);
    return;
  }
  if (kind == "filter") {  // a quiet station whose test sits behind a filter and a delay
    s.variation_rms_nT = knob("MC_RMS", s.variation_rms_nT);
    u.test_corner_hz = knob("MC_CORNER", 0.03);
    u.test_delay_s = knob("MC_DELAY", 2.0);
    return;
  }
  // Weak in-band signal, weak vertical (rms over the record; the f^-2 spectrum puts most of it
  // in the lowest harmonics).
  s.variation_rms_nT = knob("MC_RMS", 5.0) * std::sqrt(days);
  s.variation_z_ratio = knob("MC_ZRATIO", 0.2);
  s.spikes_per_day = knob("MC_SPIKES", 20);     // 50 nT glitches, despiked
  s.gap_count = static_cast<int>(knob("MC_GAPS", 2) * days);
  s.gap_length_s = knob("MC_GAP_S", 600.0);
  // Traffic: vehicles seen by the two sensors with different gains and directions.
  d.vehicles_per_day = knob("MC_VEHICLES", 150);
  d.road_distance_m = knob("MC_ROAD_M", 80.0);
  d.test_sensor_offset_m = Eigen::Vector3d(3.0, 4.0, 0.0) * knob("MC_SENSOR_SPACING", 1.0);
  d.parking_probability = knob("MC_PARKING", 0.03);
  d.small_spikes_per_day = knob("MC_SMALL_SPIKES", 50);
  d.steps = 0;
  // Test pier tilt walk: ~0.6 nT after 5 days.
  u.tilt_walk_nT_per_sqrt_day = knob("MC_TILT_WALK", 0.27);
  // Heater in the test sensor: 0.02-0.05 nT, random direction, ~30 min cycles.
  const double heater = knob("MC_HEATER", 1.0) * (0.02 + 0.03 * uniform(rng));
  Eigen::Vector3d dir(uniform(rng) - 0.5, uniform(rng) - 0.5, uniform(rng) - 0.5);
  u.heater_nT = heater * dir.normalized();
  u.heater_period_s = knob("MC_HEATER_PERIOD", 1800.0);
  // Response mismatch: test low-passed at MC_CORNER Hz (0: none) and delayed by MC_DELAY s.
  u.test_corner_hz = knob("MC_CORNER", 0.5);
  u.test_delay_s = knob("MC_DELAY", 0.2);
}

/// A geomagnetic pulsation seen by both instruments as the field is (reference += b, test += b n,
/// before any one-sensor disturbance or filter): MC_PULSATION_NT nT amplitude (0, the default:
/// none), a steady sinusoid through the record at a frequency drawn uniformly in 2-7 mHz (Pc5,
/// inside the default band), random phase and direction. A few harmonics then carry most of a
/// short window's signal, as in the real WIC hours whose covariances rest on 9-12 cells
/// (docs/validation.md, "Coverage of the intervals").
inline void add_pulsation(mic::SimulatedPair& pair, std::uint64_t seed) {
  const double amplitude = knob("MC_PULSATION_NT", 0.0);
  if (amplitude == 0.0) return;
  std::mt19937_64 rng(seed * 104729 + 3);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> normal;
  const double frequency_hz = 0.002 + 0.005 * uniform(rng), phase = 2.0 * M_PI * uniform(rng);
  const Eigen::RowVector3d direction = Eigen::RowVector3d(normal(rng), normal(rng), normal(rng)).normalized();
  const bool third_field = pair.field_nT.rows() == pair.reference.values_nT.rows();  // kept for a third
  for (Eigen::Index i = 0; i < pair.reference.values_nT.rows(); ++i) {
    const double t = pair.reference.time_s[static_cast<std::size_t>(i)] - pair.reference.time_s.front();
    const Eigen::RowVector3d b = amplitude * std::sin(2.0 * M_PI * frequency_hz * t + phase) * direction;
    pair.reference.values_nT.row(i) += b;
    pair.test.values_nT.row(i) += b * pair.n_true;
    if (third_field) pair.field_nT.row(i) += b;
  }
}

/// The records of one seed of `kind` ("quiet", "disturbed" or "filter"), `days` long; with
/// keep_clean_field, the clean field too (a third instrument's); the simulator's settings in
/// `settings` when given.
inline mic::SimulatedPair station_records(const std::string& kind, std::uint64_t seed, double days,
                                          bool keep_clean_field = false, mic::SimulationSettings* settings = nullptr) {
  mic::SimulationSettings s;
  mic::StationDisturbanceSettings d;
  mic::UnmodelledDisturbanceSettings u;
  scenario(kind, seed, days, s, d, u);
  s.keep_clean_field = keep_clean_field;
  if (settings != nullptr) *settings = s;
  mic::SimulatedPair pair = mic::simulate_pair(s);
  add_pulsation(pair, seed);
  if (kind == "disturbed") mic::add_station_disturbances(pair, d);
  if (kind != "quiet") mic::add_unmodelled_disturbances(pair, u);
  return pair;
}

}  // namespace monte_carlo
