// A modelled relative response of the test instrument: a common delay and a first-order low-pass
// per test component, fitted to the measured relative response (relative_response.hpp), and the
// correction of the test record by the inverse filter, so that n is estimated through it.
//
// Why: two instruments with different anti-alias filters differ by a relative response that is
// not flat. Eq. 2 over a band reaching the test filter's corner takes the filter's roll-off for a
// loss of gain (a 1-pole at 0.03 Hz is 0.949 at 0.01 Hz) and its phase for extra delay (group
// delay 1 / (2 pi fc) = 5.3 s at low frequency). The model
//     H_k(f) = g_k exp(-i 2 pi f tau) / (1 + i f / fc_k)
// is fitted to the bands up to fit_max_hz (lowered band by band while the model does not fit,
// chi^2 / dof > max_chi2_per_dof, so that a steeper filter above the band is not forced into a
// first-order one); g_k absorbs what n has already absorbed. Only the filter part is removed from
// the test record (multiplied by 1 + i f / fc_k in the frequency domain, held constant above the
// fitted range); the delay is left to the estimator (robust: estimated and removed; plain: reported).
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/estimation/relative_response.hpp"

#include <Eigen/Core>

#include <limits>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

struct ResponseModelSettings {
  double fit_max_hz = 0.1;        ///< highest band used in the fit, Hz
  double min_fit_max_hz = 0.02;   ///< the fit is given up when it needs to stop below this, Hz
  double max_chi2_per_dof = 2.0;  ///< a fit worse than this drops its highest band
  /// A corner is applied only when 1/fc is this many standard errors above 0, the gains alone
  /// show its roll-off (chi^2 flat - chi^2 1-pole >= min_significance^2) and the corner lies at
  /// most max_corner_above_fit times above the highest fitted band (else no filter: a roll-off
  /// extrapolated from far above the data is what reference noise does to the measured gain at
  /// high frequency). At 1.5 the 1-pole's gain at the top of the fit is 0.83: its roll-off was
  /// seen. (1.0 would miss the 0.03 Hz filter on disturbed records whose fit stops at 0.0225 Hz.)
  double min_significance = 3.0;
  double max_corner_above_fit = 1.5;

  void validate() const;  ///< throws InputError naming the field
};

struct ResponseModel {
  bool fitted = false;               ///< false: too few bands, or no fit below min_fit_max_hz
  bool applied = false;              ///< a significant corner in at least one component
  double delay_s = 0.0, delay_ci95_s = 0.0;  ///< test minus reference, s
  Eigen::Vector3d corner_hz = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());  ///< inf: none
  Eigen::Vector3d inverse_corner_s = Eigen::Vector3d::Zero();       ///< 1 / fc, s (0: no filter)
  Eigen::Vector3d inverse_corner_ci95_s = Eigen::Vector3d::Zero();  ///< 95 % half-width of 1 / fc, s
  double fit_max_hz = 0.0;           ///< highest band frequency the fit used, Hz
  double chi2_per_dof = 0.0;
  std::string text;                  ///< one line for reports: what was fitted and applied
};

/// Fits the model to the bands (frequency_hz <= settings.fit_max_hz, at least 5 bands).
ResponseModel fit_response_model(const std::vector<ResponseBand>& bands, const ResponseModelSettings& settings = {});

/// The test record (N x 3, nT, sample period period_s) with each component's significant corner
/// removed: multiplied by 1 + i f / fc_k up to model.fit_max_hz and by its value there above.
/// The straight line through the first and last samples is taken out first (no wrap-around
/// step) and put back with its filtered slope. Returns test unchanged when !model.applied.
Readings remove_modelled_filter(const Readings& test, double period_s, const ResponseModel& model);

/// The response-model step of one window (the per-window stage, window_calibration.hpp): the
/// relative response of test_nT against R n (estimate.n, as
/// estimated from test_nT), the model fitted to it and, when a corner is applied, test_nT replaced
/// by the record with the filter removed and estimate by estimate_again on it. A window whose
/// estimate is not finite is left alone (model not fitted, text says why). `remote`: the
/// window's remote when the estimate rests on it (the relative response on its instruments).
ResponseModel with_response_model(const WindowEstimateFunction& estimate_again, const Eigen::Ref<const Readings>& reference_nT,
                                  Readings& test_nT, double period_s, const RelativeResponseSettings& response,
                                  const ResponseModelSettings& model, WindowEstimate& estimate,
                                  const Readings* remote = nullptr);

}  // namespace magnetometer_insitu_calibration
