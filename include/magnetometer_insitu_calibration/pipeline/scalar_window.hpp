// The scalar check of one window (estimation/scalar_check.hpp): F of an absolute scalar
// magnetometer regressed on the window's reference, with the estimator the window's n has.
//
// The grid: the window's own epochs when the scalar samples at least as often as 1.5 times the
// window's period (its F put on them by a cubic: a straight line would lose 0.05 % of a 1 s
// scalar's amplitude at 0.01 Hz 0.37 s off whole seconds, as the GP20S3 is); else the scalar's
// own samples from its first in the window (a scalar every 30 s), the reference put at them by
// windowed sinc so that it folds the same field into the band as F does
// (band_limited_interpolation.hpp), and the window's reference noise model as the fit there sees
// it (white through the interpolation, 1/f folded in). Epochs without F are filled by straight
// lines in F and the reference alike (which keeps F = R c). Then the estimator of the window
// (default: robust, with its screen, weights, jackknife, and a delay fitted between the scalar
// and the reference) with F as each of the three test columns (so that n's three columns are c),
// and the reference noise model for the errors-in-variables correction.
#pragma once

#include "magnetometer_insitu_calibration/estimation/window_estimator.hpp"
#include "magnetometer_insitu_calibration/estimation/scalar_check.hpp"
#include "magnetometer_insitu_calibration/common/scalar_record.hpp"
#include "magnetometer_insitu_calibration/preprocessing/gap_filling.hpp"
#include "magnetometer_insitu_calibration/preprocessing/gaussian_decimation.hpp"
#include "magnetometer_insitu_calibration/preprocessing/time_alignment.hpp"

#include <optional>

namespace magnetometer_insitu_calibration {

/// window: the pair on its grid, filled (reference frame and test frame, nT); period_s its
/// period; estimate: the window's estimate of n (with its covariance). Never throws for data:
/// a window the scalar cannot check says why in ScalarCheck::text. `decimation`: the low-pass
/// and decimation the pair went through, if it did; F as dense as the pair's epochs goes through
/// the same onto them (decimate_scalar), or the pair's gain would be read as the reference's scale.
ScalarCheck check_scalar(const ScalarRecord& scalar, const PairedRecord& window, double period_s,
                         const WindowEstimate& estimate, WindowEstimator& estimator, const WindowInputs& inputs,
                         const GapSettings& gaps, const std::optional<FieldDirection>& given,
                         const std::optional<DecimationSettings>& decimation);

}  // namespace magnetometer_insitu_calibration
