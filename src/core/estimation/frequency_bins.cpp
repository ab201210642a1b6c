// Log-spaced frequency bins: see frequency_bins.hpp.
#include "magnetometer_insitu_calibration/estimation/frequency_bins.hpp"

#include <cmath>

namespace magnetometer_insitu_calibration {

std::vector<double> log_spaced_bin_edges(double low_hz, double high_hz, int bins) {
  std::vector<double> edges;
  const double ratio = std::pow(high_hz / low_hz, 1.0 / bins);
  for (int k = 0; k < bins; ++k) edges.push_back(low_hz * std::pow(ratio, k));
  edges.push_back(high_hz);
  return edges;
}

}  // namespace magnetometer_insitu_calibration
