// A further instrument beside a simulated pair (simulator.hpp), for the three-cornered hat
// (pipeline/reference_noise.hpp): it records the pair's clean field B (reference frame, nT,
// SimulatedPair::field_nT with keep_clean_field) through its own matrix n, T = B n, plus white
// noise from its own random generator. Used by the hat's tests and Monte Carlo programs.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <Eigen/Core>

#include <cstdint>

namespace magnetometer_insitu_calibration {

/// The third instrument's matrix in those tests and programs (calibration_matrix.hpp's angles):
/// scale ratios 1.0003, 0.9995, 1.0002; non-orthogonality 0.02, -0.01, 0 deg; misalignment
/// -0.1, 0.2, 0.05 deg.
Eigen::Matrix3d co_located_instrument_matrix();

/// field_nT n plus white noise of white_nT rms per sample and component (nT): standard normal
/// draws from std::mt19937_64(rng_seed), sample by sample, x, y, z.
Readings co_located_instrument(const Readings& field_nT, const Eigen::Matrix3d& n, double white_nT,
                               std::uint64_t rng_seed);

}  // namespace magnetometer_insitu_calibration
