// Internal helper shared by the plain (fd_wlse.cpp) and the robust (robust_estimator.cpp)
// estimators: the WindowEstimate of a window that could not be estimated.
// Not installed: src/core only.
#pragma once

#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"

#include <limits>
#include <string>

namespace magnetometer_insitu_calibration::detail {

/// `result` with every estimated quantity (n, its covariance, the trend in nT/day and its
/// standard error, the condition number, coherence, residual RMS in nT) set to NaN, the
/// parameters decomposed from that NaN n, and the quality set to q with its text. Fields that
/// describe the window (samples, sample period, harmonics, method) are kept.
inline WindowEstimate failed_window_estimate(WindowEstimate result, Quality q, const std::string& text) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  result.n.setConstant(kNaN);
  result.n_covariance.setConstant(kNaN);
  result.trend_nT_per_day.setConstant(kNaN);
  result.trend_stderr_nT_per_day.setConstant(kNaN);
  result.parameters = decompose(result.n);
  result.condition_number = kNaN;
  result.coherence.setConstant(kNaN);
  result.residual_rms_nT.setConstant(kNaN);
  result.quality = q;
  result.quality_text = text;
  return result;
}

}  // namespace magnetometer_insitu_calibration::detail
