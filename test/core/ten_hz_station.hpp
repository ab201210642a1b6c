// Shared by the tests of records and streams of two rates or phases: a LEMI-025 station at 10 Hz
// and 1 s records taken from it at either phase of the second.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <cstdint>

namespace magnetometer_insitu_calibration::test {

/// `hours` of the simulator's pair at 10 Hz on the LEMI-025 grid: samples at x.7, x.8, ... (its
/// -0.3 s shift), without the clean field.
inline SimulationSettings ten_hz_station(std::uint64_t seed, double hours = 6.0) {
  SimulationSettings s;
  s.seed = seed;
  s.duration_s = hours * 3600.0;
  s.sample_period_s = 0.1;
  s.start_time_s = 1747180800.0 - 0.3;
  s.keep_clean_field = false;
  return s;
}

/// A 1 s record from a 10 Hz one: samples first, first + 10, ... (on the ten_hz_station grid
/// x.7, x.8, ...: whole seconds from index 3, x.3 from index 6).
inline VectorRecord every_tenth(const VectorRecord& r, Eigen::Index first) {
  VectorRecord out = r;
  const Eigen::Index count = (static_cast<Eigen::Index>(r.size()) - first) / 10;
  out.time_s.resize(static_cast<std::size_t>(count));
  out.values_nT.resize(count, 3);
  for (Eigen::Index i = 0; i < count; ++i) {
    out.time_s[static_cast<std::size_t>(i)] = r.time_s[static_cast<std::size_t>(first + 10 * i)];
    out.values_nT.row(i) = r.values_nT.row(first + 10 * i);
  }
  return out;
}

}  // namespace magnetometer_insitu_calibration::test
