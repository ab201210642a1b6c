// A field hut's temperature and what it does to the test fluxgate, added to a
// simulated pair (simulator.hpp) after simulate_pair() and any other disturbances.
//
// Temperature of the test sensor, deg C, at UNIX time t (s UTC):
//   theta(t) = mean_C + daily_amplitude_C cos(2 pi (t mod 86400 - daily_peak_s) / 86400)
//            + heater(t)
// heater(t): a thermostat cycling the sensor's housing, a triangle wave between
// -heater_amplitude_C and +heater_amplitude_C (warming for heater_duty of each cycle, then
// cooling); cycle lengths uniform in heater_period_s (1 +- heater_period_jitter), random start
// phase. Typical: a few deg C daily, a few tenths of a deg C every tens of minutes.
//
// What the test reads (test frame, per component l, nT), with d = theta - reference_C:
//   T_l <- T_l (1 + 1e-6 scale_ppm_per_C_l d) + offset_nT_per_C_l d
// i.e. n is n_true at reference_C, scale factors change by scale_ppm_per_C ppm per deg C and the
// offsets by offset_nT_per_C nT per deg C (fluxgates: tenths of nT/degC and 10-30 ppm/degC).
//
// The record gets the thermometer's reading as the auxiliary channel "sensor_temperature"
// (degC): theta plus white noise of thermometer_noise_C, rounded to thermometer_resolution_C
// (LEMI-025: 0.01 deg C), NaN where the test reading is NaN (one packet carries both).
#pragma once

#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace magnetometer_insitu_calibration {

struct HutTemperatureSettings {
  std::uint64_t seed = 1;
  double mean_C = 20.0;                 ///< deg C
  double daily_amplitude_C = 3.0;       ///< deg C, amplitude of the 24 h cycle (>= 0)
  double daily_peak_s = 14.0 * 3600.0;  ///< s after 00:00 UTC of the daily maximum
  double heater_amplitude_C = 0.3;      ///< deg C, half the peak-to-peak of the heater cycle (>= 0)
  double heater_period_s = 1800.0;      ///< mean cycle length, s (> 0)
  double heater_period_jitter = 0.2;    ///< cycle lengths uniform in period (1 +- jitter), [0, 0.9]
  double heater_duty = 0.4;             ///< share of a cycle spent warming, (0, 1)
  double reference_C = 20.0;            ///< deg C at which the test's matrix is n_true
  Eigen::Vector3d offset_nT_per_C{0.2, -0.15, 0.3};   ///< nT per deg C, test frame
  Eigen::Vector3d scale_ppm_per_C{15.0, -10.0, 25.0};  ///< ppm per deg C, test frame
  double thermometer_noise_C = 0.005;       ///< deg C rms, white (>= 0)
  double thermometer_resolution_C = 0.01;   ///< deg C; 0: not rounded

  void validate() const;  ///< throws InputError naming the field
};

struct HutTemperatureReport {
  std::vector<double> temperature_C;  ///< theta at each sample, deg C (true, not the reading)
  std::size_t heater_cycles = 0;
};

/// Applies the temperature effect to pair.test in place and appends the thermometer channel
/// "sensor_temperature" to pair.test.auxiliary. Deterministic for a given seed.
HutTemperatureReport add_hut_temperature(SimulatedPair& pair, const HutTemperatureSettings& settings);

}  // namespace magnetometer_insitu_calibration
