// The median step between a record's time stamps: its nominal sample period, s, whatever its
// gaps and odd stamps; and where in each period the stamps fall. One definition for the readers,
// the pre-processing, the scalar check and the live streams' monitors.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
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

/// Where in each period of period_s the stamps fall: the circular mean of t mod period_s over up
/// to 4096 evenly spread stamps, s in [-period/2, period/2). NaN when they have no common phase
/// (the mean resultant length under 0.5: stamps off any grid) or there are none.
inline double stamp_phase_s(const std::vector<double>& time_s, double period_s) {
  constexpr double kPi = 3.14159265358979323846;
  const std::size_t stride = std::max<std::size_t>(1, time_s.size() / 4096);
  double c = 0.0, s = 0.0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < time_s.size(); i += stride, ++count) {
    const double angle = 2.0 * kPi * std::fmod(time_s[i], period_s) / period_s;
    c += std::cos(angle);
    s += std::sin(angle);
  }
  if (count == 0 || std::hypot(c, s) < 0.5 * static_cast<double>(count)) return std::numeric_limits<double>::quiet_NaN();
  return std::atan2(s, c) / (2.0 * kPi) * period_s;
}

/// The phase `phase_s` relative to `from_s` (both from stamp_phase_s at period_s), wrapped to
/// [-period/2, period/2], s; NaN when either is.
inline double phase_offset_s(double phase_s, double from_s, double period_s) {
  const double d = phase_s - from_s;
  return d - period_s * std::round(d / period_s);
}

}  // namespace magnetometer_insitu_calibration
