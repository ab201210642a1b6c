// A simulated pair in a field hut with known temperature coefficients (hut_temperature.hpp),
// shared by the temperature tests of the core and of the ROS layer. Header-only.
#pragma once

#include "magnetometer_insitu_calibration/simulation/hut_temperature.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <Eigen/Core>

#include <cstdint>

namespace magnetometer_insitu_calibration::test {

struct HutPair {
  SimulatedPair pair;             ///< pair.test carries the auxiliary channel "sensor_temperature"
  HutTemperatureSettings hut;     ///< the truth: coefficients, reference temperature
  /// The thermometer's reading as a vector (deg C), one per sample.
  Eigen::VectorXd reading_C() const {
    const auto& v = pair.test.auxiliary.at(0).values;
    return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
  }
};

/// simulate_pair (defaults, 1 Hz, `duration_s` long) then add_hut_temperature (defaults), both
/// with `seed`.
inline HutPair hut_pair(std::uint64_t seed, double duration_s) {
  HutPair h;
  SimulationSettings s;
  s.seed = seed;
  s.duration_s = duration_s;
  s.keep_clean_field = false;
  h.pair = simulate_pair(s);
  h.hut.seed = seed;
  add_hut_temperature(h.pair, h.hut);
  return h;
}

}  // namespace magnetometer_insitu_calibration::test
