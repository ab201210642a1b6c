// Log-spaced frequency bins, as the noise estimates use them (the three-cornered hat, the pair's
// noise above the band, the hat's bins over and above the band).
#pragma once

#include <vector>

namespace magnetometer_insitu_calibration {

/// bins + 1 edges (Hz) of `bins` log-spaced bins over [low_hz, high_hz]: low_hz r^k for
/// k = 0 .. bins - 1, then high_hz itself (r = (high_hz / low_hz)^(1 / bins)). Bin k is
/// [edges[k], edges[k + 1]). Assumes 0 < low_hz < high_hz and bins >= 1 (callers check).
std::vector<double> log_spaced_bin_edges(double low_hz, double high_hz, int bins);

}  // namespace magnetometer_insitu_calibration
