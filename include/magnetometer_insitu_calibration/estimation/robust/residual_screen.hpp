// The robust estimator's residual screen (robust_estimator.hpp, step 1) on its own: the samples
// where the residual T - R n (test frame, nT), high-passed by a running median, is an outlier.
// Exposed for tests and for the real-data report.
#pragma once

#include "magnetometer_insitu_calibration/estimation/estimator_settings.hpp"
#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <Eigen/Core>

#include <vector>

namespace magnetometer_insitu_calibration {

/// Per sample 1 where T - R n, high-passed, is an outlier (margin included), else 0.
/// reference_nT, test_nT: N x 3, nT; sample_period_s in s; settings: the screen's fields.
std::vector<char> screen_residual(const Eigen::Ref<const Readings>& reference_nT,
                                  const Eigen::Ref<const Readings>& test_nT, const Eigen::Matrix3d& n,
                                  double sample_period_s, const RobustSettings& settings);

}  // namespace magnetometer_insitu_calibration
