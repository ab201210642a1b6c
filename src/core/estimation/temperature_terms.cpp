// The temperature terms of one window estimate: see temperature_terms.hpp.
#include "magnetometer_insitu_calibration/estimation/temperature_terms.hpp"

#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"

#include <cmath>

namespace magnetometer_insitu_calibration {

TemperatureFit with_temperature_terms(const WindowEstimateFunction& estimate_again, const EstimatorSettings& settings,
                                      const TemperatureBand& band_settings, const Eigen::Ref<const Readings>& reference_nT,
                                      Readings& test_nT, const Eigen::Ref<const Eigen::VectorXd>& temperature_C,
                                      double sample_period_s, WindowEstimate& estimate) {
  TemperatureBand band = band_settings;
  band.low_hz = std::isfinite(estimate.band_low_hz) ? estimate.band_low_hz : settings.band_low_hz;
  band.high_hz = std::isfinite(estimate.band_high_hz) ? estimate.band_high_hz : settings.band_high_hz;
  band.gamma = settings.gamma;
  band.trend = settings.trend;
  if (!estimate.n.allFinite()) {
    TemperatureFit none;
    none.text = "temperature terms not fitted: the window's estimate of n is not finite";
    return none;
  }
  const Eigen::Matrix3d n0 = estimate.n;
  TemperatureFit fit = fit_temperature(reference_nT, test_nT, temperature_C, sample_period_s, n0, band);
  if (!fit.fitted) return fit;
  test_nT = remove_temperature_terms(reference_nT, test_nT, temperature_C, n0, fit);
  estimate = estimate_again(reference_nT, test_nT, sample_period_s);
  if (estimate.n.allFinite()) {
    estimate.n_covariance += fit.coupling * fit.covariance * fit.coupling.transpose();
    estimate.parameters = decompose(estimate.n, estimate.n_covariance, estimate.covariance_dof);
    // c = a - s F with F from the n published with the terms, not n0 (correction_node's lever).
    refer_offset_to_mean_field(fit, (reference_nT.colwise().mean() * estimate.n).transpose());
  }
  return fit;
}

}  // namespace magnetometer_insitu_calibration
