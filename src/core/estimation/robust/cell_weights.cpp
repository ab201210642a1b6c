// The M-step's weight functions (cell_weights.hpp).
#include "magnetometer_insitu_calibration/estimation/robust/cell_weights.hpp"

namespace magnetometer_insitu_calibration {

double HuberWeights::weight(double standardised_residual) const {
  return standardised_residual <= k_sigmas_ ? 1.0 : k_sigmas_ / standardised_residual;
}

double UnitWeights::weight(double /*standardised_residual*/) const { return 1.0; }

double RejectingWeights::weight(double standardised_residual) const {
  return standardised_residual > limit_sigmas_ ? 0.0 : inner_.weight(standardised_residual);
}

}  // namespace magnetometer_insitu_calibration
