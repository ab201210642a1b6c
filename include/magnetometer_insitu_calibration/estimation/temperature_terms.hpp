// The temperature terms of one window estimate, shared by the offline pipeline
// (calibrate_prepared) and calibration_node (live_window): fit_temperature with n0 = the window's
// estimate, the fitted terms removed from T, n estimated again (then at the window's mean
// temperature, TemperatureFit::reference_C) and the coefficients' uncertainty added to n's
// covariance (coupling * covariance * coupling^T), parameters decomposed again.
#pragma once

#include "magnetometer_insitu_calibration/estimation/window_estimator.hpp"
#include "magnetometer_insitu_calibration/estimation/temperature_regression.hpp"


namespace magnetometer_insitu_calibration {

/// Fits the temperature terms of a window already estimated (`estimate`, from `test` as given)
/// over the estimate's band (or settings' band when the estimate has none), with settings' gamma
/// and trend column and band.min_range_C; band.low_hz/high_hz/gamma/trend of `band` are not used.
/// When fitted: `test` loses the terms (in place), `estimate` is replaced by estimate_again on it,
/// with the coefficients' uncertainty in n_covariance and parameters. Not fitted (text says why):
/// test and estimate are unchanged. A non-finite estimate.n: not fitted, text says so.
TemperatureFit with_temperature_terms(const WindowEstimateFunction& estimate_again, const EstimatorSettings& settings,
                                      const TemperatureBand& band, const Eigen::Ref<const Readings>& reference_nT,
                                      Readings& test_nT, const Eigen::Ref<const Eigen::VectorXd>& temperature_C,
                                      double sample_period_s, WindowEstimate& estimate);

}  // namespace magnetometer_insitu_calibration
