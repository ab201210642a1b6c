// A record advanced in time by a phase shift over the whole window (delay_estimation.hpp).
#include "magnetometer_insitu_calibration/estimation/delay_estimation.hpp"

#include "magnetometer_insitu_calibration/estimation/column_response.hpp"

#include <cmath>
#include <complex>

namespace magnetometer_insitu_calibration {

Readings advance_record(const Eigen::Ref<const Readings>& x, double sample_period_s, double advance_s) {
  Readings out = x;
  const auto n = static_cast<std::size_t>(x.rows());
  if (n < 4 || advance_s == 0.0) return out;
  ColumnResponse filter(n);
  // x(t + tau): e^{+2 pi i f tau} on the DFT; the line a + b t becomes a + b (t + tau).
  const auto advance = [&](double f) { return std::polar(1.0, 2.0 * M_PI * f * advance_s); };
  for (Eigen::Index k = 0; k < x.cols(); ++k) filter.apply(x.col(k), sample_period_s, advance, advance_s, out.col(k));
  return out;
}

}  // namespace magnetometer_insitu_calibration
