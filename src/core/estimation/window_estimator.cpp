// The estimators' front door (window_estimator.hpp): the estimate's own functions, and the
// dispatcher that gives each window the estimator its settings ask for: plain Eq. 2 (with auto
// band and the delay reported) or the robust estimator (robust/robust_estimator.hpp).
#include "magnetometer_insitu_calibration/estimation/window_estimator.hpp"

#include "magnetometer_insitu_calibration/estimation/band_selection.hpp"
#include "magnetometer_insitu_calibration/estimation/delay_estimation.hpp"
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/estimation/robust/robust_estimator.hpp"

#include <algorithm>
#include <cmath>

namespace magnetometer_insitu_calibration {

const char* quality_name(Quality q) {
  switch (q) {
    case Quality::kOk: return "ok";
    case Quality::kTooFewSamples: return "too_few_samples";
    case Quality::kTooFewHarmonics: return "too_few_harmonics";
    case Quality::kIllConditioned: return "ill_conditioned";
    case Quality::kLowCoherence: return "low_coherence";
    case Quality::kGaps: return "gaps";
    case Quality::kNotFinite: return "not_finite";
  }
  return "unknown";
}

Eigen::Matrix3d WindowEstimate::n_stderr() const {
  Eigen::Matrix3d se;
  for (int k = 0; k < 9; ++k) se(k / 3, k % 3) = std::sqrt(std::max(0.0, n_covariance(k, k)));
  return se;
}

WindowEstimator::WindowEstimator(const EstimatorSettings& settings) : settings_(settings) {
  settings_.validate();
  if (settings_.method == EstimatorMethod::kRobust) robust_ = std::make_unique<RobustFdEstimator>(settings_);
}

WindowEstimator::~WindowEstimator() = default;

const RobustDiagnostics* WindowEstimator::robust_diagnostics() const {
  return robust_ ? &robust_->diagnostics() : nullptr;
}

WindowEstimate WindowEstimator::estimate(const Eigen::Ref<const Readings>& reference_nT,
                                         const Eigen::Ref<const Readings>& test_nT, double sample_period_s,
                                         const WindowInputs& inputs) {
  if (robust_) return robust_->estimate(reference_nT, test_nT, sample_period_s, inputs);
  EstimatorSettings s = settings_;
  const double duration_s = static_cast<double>(reference_nT.rows()) * sample_period_s;
  if (s.robust.auto_band && reference_nT.allFinite() && test_nT.allFinite() && reference_nT.rows() >= 64) {
    BandSelectionSettings bs;
    bs.search_low_hz = s.robust.band_search_low_hz;
    bs.search_high_hz = s.robust.band_search_high_hz;
    bs.min_coherence = s.robust.min_band_coherence;
    bs.min_band_harmonics = s.min_harmonics;
    const BandSelection band = select_band(reference_nT, test_nT, sample_period_s, bs);
    if (band.ok) {
      s.band_low_hz = band.low_hz;
      s.band_high_hz = band.high_hz;
    }
  }
  FdWlseEstimator plain(s);
  WindowEstimate e = plain.estimate(reference_nT, test_nT, sample_period_s, inputs);
  e.method = "plain";
  e.band_low_hz = static_cast<double>(e.harmonic_first) / duration_s;
  e.band_high_hz = static_cast<double>(e.harmonic_last) / duration_s;
  if (s.robust.estimate_delay && e.n.allFinite()) {
    DelaySettings ds;
    ds.low_hz = std::max(e.band_low_hz, 2.0 / duration_s);
    ds.high_hz = std::max(s.robust.delay_max_hz, 2.0 * ds.low_hz);
    const DelayEstimate d = estimate_delay(reference_nT, test_nT, e.n, sample_period_s, ds);
    if (d.ok) {
      e.delay_s = d.delay_s;
      e.delay_ci95_s = d.ci95_s;
    }
  }
  return e;
}

}  // namespace magnetometer_insitu_calibration
