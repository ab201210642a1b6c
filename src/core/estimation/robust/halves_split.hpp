// Without a remote, the pair tested against itself over the robust estimator's cells
// (remote_reference.hpp, BandSplitCheck): n of the band's lower and upper halves, and n of the
// sections with the least and the most field (the activity split), each pair of halves compared,
// and their spread beyond the noise added to n's covariance. Not installed: src/core only.
#pragma once

#include "section_cells.hpp"
#include "section_irls.hpp"

#include "magnetometer_insitu_calibration/estimation/errors_in_variables.hpp"
#include "magnetometer_insitu_calibration/estimation/remote_reference.hpp"
#include "magnetometer_insitu_calibration/estimation/window_estimator.hpp"

#include <cstddef>
#include <vector>

namespace magnetometer_insitu_calibration::detail::robust {

/// The band-split check (remote_reference.hpp) over the cells with the fit's final weights, with
/// the activity split's p-value and both splits' spread (BandSplitCheck::spread_covariance).
BandSplitCheck band_split_check(const std::vector<Cell>& cells, const IrlsResult& fit, std::size_t k_sections,
                                std::size_t bins, const ReferenceNoiseModel* noise, const Regression& regression);

/// Adds the check's spread_covariance to the pair-only window's n covariance and decomposes its
/// parameters again (the intervals then carry the halves' disagreement beyond their noise); the
/// intervals' text says so. Nothing when the spread is zero.
void widen_by_halves_spread(WindowEstimate& result);

}  // namespace magnetometer_insitu_calibration::detail::robust
