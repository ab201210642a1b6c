// An absolute scalar magnetometer beside a simulated pair (simulator.hpp): F = |B| at its own
// times, with its own noise and gaps, for the scalar check (estimation/scalar_check.hpp).
//   F(t_k) = |B(t_k)| + noise_k,  t_k = start + offset_s + k period_s
// B(t_k) from the pair's clean field (SimulatedPair::field_nT) as the band-limited record it is
// (Lanczos, 32 samples each side: band_limited_interpolation.hpp); an instantaneous sample, as
// optically pumped and Overhauser instruments take it. (A straight line between the samples lost
// up to 0.05 % of F's amplitude at 0.01 Hz, which the 1 s check read as the reference's scale.)
#pragma once

#include "magnetometer_insitu_calibration/common/scalar_record.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <cstdint>

namespace magnetometer_insitu_calibration {

struct ScalarMagnetometerSettings {
  std::uint64_t seed = 1;
  double period_s = 1.0;    ///< between samples, s (1: a GP20S3; 30: many proton instruments)
  double offset_s = 0.37;   ///< first sample after the record's start, s (stamps off whole seconds)
  double white_nT = 0.01;   ///< rms per sample, nT
  int gap_count = 0;        ///< NaN runs of gap_length_s
  double gap_length_s = 600.0;

  void validate() const;  ///< throws InputError naming the field
};

/// Its record over the pair's span. Throws InputError for impossible settings or a pair without
/// its clean field.
ScalarRecord simulate_scalar_magnetometer(const SimulatedPair& pair, const ScalarMagnetometerSettings& settings);

}  // namespace magnetometer_insitu_calibration
