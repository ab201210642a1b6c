// A simulated scalar magnetometer: see scalar_magnetometer.hpp.
#include "magnetometer_insitu_calibration/simulation/scalar_magnetometer.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/preprocessing/band_limited_interpolation.hpp"
#include "magnetometer_insitu_calibration/simulation/power_law_noise.hpp"

#include <cmath>
#include <limits>

namespace magnetometer_insitu_calibration {

namespace {

/// Samples on each side for the simulated field between its samples: twice the scalar check's
/// own (kLanczosHalfWidth), so that the check is measured against a field closer to band-limited
/// than its interpolation.
constexpr int kSimulatedFieldHalfWidth = 2 * kLanczosHalfWidth;

}  // namespace

void ScalarMagnetometerSettings::validate() const {
  if (!(period_s > 0.0) || !std::isfinite(period_s)) throw InputError("period_s", "must be a positive time in s");
  if (!(offset_s >= 0.0) || !std::isfinite(offset_s)) throw InputError("offset_s", "must be a time >= 0 s");
  if (!(white_nT >= 0.0) || !std::isfinite(white_nT)) throw InputError("white_nT", "must be >= 0 nT");
  if (gap_count < 0) throw InputError("gap_count", "must be >= 0");
  if (!(gap_length_s > 0.0)) throw InputError("gap_length_s", "must be positive");
}

ScalarRecord simulate_scalar_magnetometer(const SimulatedPair& pair, const ScalarMagnetometerSettings& settings) {
  settings.validate();
  const Readings& b = pair.field_nT;
  const std::vector<double>& t = pair.reference.time_s;
  if (b.rows() < 2 || b.rows() != static_cast<Eigen::Index>(t.size())) {
    throw InputError("keep_clean_field", "the pair must keep its clean field for a scalar magnetometer");
  }
  const double dt = t[1] - t[0];
  SimulationRng rng(settings.seed, 53);
  ScalarRecord out;
  out.source = "simulated scalar magnetometer";
  out.station = "SIM";
  for (double time = t.front() + settings.offset_s; time <= t.back(); time += settings.period_s) out.time_s.push_back(time);
  // The field between its samples as the band-limited record it is (the simulator's field is
  // synthesised on the grid): an instrument that reads F at its instant has no interpolation loss.
  const Readings field = interpolate_regular(b, t.front(), dt, out.time_s, kSimulatedFieldHalfWidth);
  for (Eigen::Index k = 0; k < field.rows(); ++k) out.value_nT.push_back(field.row(k).norm() + settings.white_nT * rng.normal());
  const auto gap = static_cast<std::size_t>(std::max(1.0, std::round(settings.gap_length_s / settings.period_s)));
  for (int g = 0; g < settings.gap_count && out.size() > gap; ++g) {
    const auto first = static_cast<std::size_t>(rng.uniform_index(out.size() - gap));
    for (std::size_t k = first; k < first + gap; ++k) out.value_nT[k] = std::numeric_limits<double>::quiet_NaN();
  }
  return out;
}

}  // namespace magnetometer_insitu_calibration
