// Shared by the estimation tests that compare one-hour windows: an hour of the simulator's
// default quiet station and the settings of the paper's plain Eq. 2.
#pragma once

#include "magnetometer_insitu_calibration/estimation/robust/robust_estimator.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

namespace magnetometer_insitu_calibration::test {

/// One hour at 1 Hz of the simulator's default quiet station (36 harmonics in the default band,
/// 0.0002-0.01 Hz), without the clean field.
inline SimulatedPair simulated_hour(unsigned long long seed) {
  SimulationSettings s;
  s.seed = seed;
  s.duration_s = 3600.0;
  s.keep_clean_field = false;
  return simulate_pair(s);
}

/// Estimator settings of the paper's plain Eq. 2 (calibrate_records --method plain).
inline EstimatorSettings plain_eq2_settings() {
  EstimatorSettings settings;
  settings.method = EstimatorMethod::kPlain;
  return settings;
}

}  // namespace magnetometer_insitu_calibration::test
