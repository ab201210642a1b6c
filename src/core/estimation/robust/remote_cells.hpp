// The remote reference over the robust estimator's cells (remote_reference.hpp): the remote's
// strength and the pair-only estimate against the remote's (without a remote, the pair's
// halves: halves_split.hpp). Not installed: src/core only.
#pragma once

#include "section_cells.hpp"
#include "section_irls.hpp"

#include "magnetometer_insitu_calibration/estimation/errors_in_variables.hpp"
#include "magnetometer_insitu_calibration/estimation/remote_reference.hpp"

#include <cstddef>
#include <vector>

namespace magnetometer_insitu_calibration::detail::robust {

/// coherence, canonical coherence and first-stage F of the remote over the cells and weights.
void assess_cells_remote_strength(RemoteReference& remote, const std::vector<Cell>& cells,
                                  const std::vector<double>& weight);
/// The pair-only estimate (least squares with `pair`'s noise correction) with the remote fit's
/// final weights, the covariance of its difference from the remote's n (per-cell influence
/// difference, raised to the jackknife of the difference over the same groups, plus the
/// correction's noise-level term when `noise` corrected the pair: the remote's n has no
/// correction, so a level error moves the difference in every cell alike) and the test.
void assess_cells_pair_difference(RemoteReference& remote, const std::vector<Cell>& cells, const IrlsResult& fit,
                                  std::size_t k_sections, const Regression& pair, const Regression& iv,
                                  const ReferenceNoiseModel* noise, double covariance_cells);

}  // namespace magnetometer_insitu_calibration::detail::robust
