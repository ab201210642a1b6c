// The median step between a record's time stamps: its nominal sample period, s, whatever its
// gaps and odd stamps. One definition for the readers, the pre-processing and the scalar check.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace magnetometer_insitu_calibration {

/// Median of time_s[i + 1] - time_s[i], s; 0 with fewer than two stamps.
inline double median_time_step(const std::vector<double>& time_s) {
  if (time_s.size() < 2) return 0.0;
  std::vector<double> steps(time_s.size() - 1);
  for (std::size_t i = 0; i + 1 < time_s.size(); ++i) steps[i] = time_s[i + 1] - time_s[i];
  const auto middle = steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2);
  std::nth_element(steps.begin(), middle, steps.end());
  return *middle;
}

}  // namespace magnetometer_insitu_calibration
