// Hut temperature and its effect on the test sensor: see hut_temperature.hpp.
#include "magnetometer_insitu_calibration/simulation/hut_temperature.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/simulation/power_law_noise.hpp"

#include <cmath>

namespace magnetometer_insitu_calibration {

namespace {

constexpr std::uint64_t kHeaterStream = 41;       // RNG streams (independent of the simulator's)
constexpr std::uint64_t kThermometerStream = 42;

bool finite_at_least(double value, double minimum) { return std::isfinite(value) && value >= minimum; }

}  // namespace

void HutTemperatureSettings::validate() const {
  if (!std::isfinite(mean_C)) throw InputError("mean_C", "must be a finite temperature in deg C");
  if (!finite_at_least(daily_amplitude_C, 0.0)) throw InputError("daily_amplitude_C", "must be >= 0 deg C");
  if (!std::isfinite(daily_peak_s)) throw InputError("daily_peak_s", "must be a finite time of day in s");
  if (!finite_at_least(heater_amplitude_C, 0.0)) throw InputError("heater_amplitude_C", "must be >= 0 deg C");
  if (!(heater_period_s > 0.0) || !std::isfinite(heater_period_s)) throw InputError("heater_period_s", "must be > 0 s");
  if (!(heater_period_jitter >= 0.0 && heater_period_jitter <= 0.9))
    throw InputError("heater_period_jitter", "must be in [0, 0.9]");
  if (!(heater_duty > 0.0 && heater_duty < 1.0)) throw InputError("heater_duty", "must be in (0, 1)");
  if (!std::isfinite(reference_C)) throw InputError("reference_C", "must be a finite temperature in deg C");
  if (!offset_nT_per_C.allFinite()) throw InputError("offset_nT_per_C", "must be finite (nT per deg C)");
  if (!scale_ppm_per_C.allFinite()) throw InputError("scale_ppm_per_C", "must be finite (ppm per deg C)");
  if (!finite_at_least(thermometer_noise_C, 0.0)) throw InputError("thermometer_noise_C", "must be >= 0 deg C");
  if (!finite_at_least(thermometer_resolution_C, 0.0))
    throw InputError("thermometer_resolution_C", "must be >= 0 deg C (0: not rounded)");
}

HutTemperatureReport add_hut_temperature(SimulatedPair& pair, const HutTemperatureSettings& s) {
  s.validate();
  VectorRecord& test = pair.test;
  const std::size_t n = test.size();
  HutTemperatureReport report;
  report.temperature_C.resize(n);

  // Heater: triangle cycles of random length; phase = position in the current cycle.
  SimulationRng heater_rng(s.seed, kHeaterStream);
  auto cycle_length = [&] { return s.heater_period_s * (1.0 + s.heater_period_jitter * (2.0 * heater_rng.uniform() - 1.0)); };
  double cycle_s = cycle_length();
  double cycle_start_s = (n > 0 ? test.time_s.front() : 0.0) - heater_rng.uniform() * cycle_s;
  for (std::size_t i = 0; i < n; ++i) {
    const double t = test.time_s[i];
    while (t >= cycle_start_s + cycle_s) {
      cycle_start_s += cycle_s;
      cycle_s = cycle_length();
      ++report.heater_cycles;
    }
    const double phase = (t - cycle_start_s) / cycle_s;  // [0, 1)
    const double ramp = phase < s.heater_duty ? phase / s.heater_duty : (1.0 - phase) / (1.0 - s.heater_duty);
    const double heater = s.heater_amplitude_C * (2.0 * ramp - 1.0);
    const double time_of_day = std::fmod(t, 86400.0);
    const double daily = s.daily_amplitude_C * std::cos(2.0 * M_PI * (time_of_day - s.daily_peak_s) / 86400.0);
    report.temperature_C[i] = s.mean_C + daily + heater;
  }

  SimulationRng thermometer_rng(s.seed, kThermometerStream);
  AuxiliaryChannel reading{"sensor_temperature", "T_sensor (simulated hut)", "degC", std::vector<double>(n)};
  for (std::size_t i = 0; i < n; ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    const double d = report.temperature_C[i] - s.reference_C;
    for (int l = 0; l < 3; ++l) {
      double& value = test.values_nT(row, l);
      value = value * (1.0 + 1e-6 * s.scale_ppm_per_C(l) * d) + s.offset_nT_per_C(l) * d;
    }
    double measured = report.temperature_C[i] + s.thermometer_noise_C * thermometer_rng.normal();
    if (s.thermometer_resolution_C > 0.0) measured = std::round(measured / s.thermometer_resolution_C) * s.thermometer_resolution_C;
    reading.values[i] = test.values_nT.row(row).allFinite() ? measured : std::nan("");
  }
  test.auxiliary.push_back(std::move(reading));
  return report;
}

}  // namespace magnetometer_insitu_calibration
