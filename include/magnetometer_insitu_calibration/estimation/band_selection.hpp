// Automatic choice of the estimation band from the coherence between the two instruments.
//
// The paper fixes 0.0002-0.01 Hz by hand: below, baseline drift and tilts of the sensors; above,
// too little geomagnetic signal against the instrument noise. Both limits show in the squared
// multiple coherence of each test component with the three reference components,
//   gamma_l^2(f) = S_TlR S_RR^-1 S_RTl / S_TlTl       (dimensionless, 0..1),
// estimated in log-spaced frequency bins from the DFT of the whole window (both records linearly
// detrended and Hann-tapered alike, which keeps T = R n + d). Drift, tilt and noise are the parts
// of T that R does not explain, so they lower gamma^2 exactly where they matter. The band is
// the widest contiguous run of bins (most harmonics) inside the search range where every
// component reaches min_coherence.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

struct BandSelectionSettings {
  double search_low_hz = 0.0001;  ///< lowest frequency considered, Hz
  double search_high_hz = 0.05;   ///< highest frequency considered, Hz
  double min_coherence = 0.9;     ///< squared multiple coherence each component must reach
  int bins_per_decade = 12;       ///< log-spaced bins
  std::size_t min_bin_harmonics = 12;  ///< a bin holds at least this many harmonics (merged)
  std::size_t min_band_harmonics = 16; ///< a band with fewer harmonics is not accepted

  void validate() const;  ///< throws InputError naming the field
};

struct CoherenceBin {
  double low_hz = 0.0, high_hz = 0.0;  ///< harmonic frequencies at the bin's edges, Hz
  std::size_t harmonics = 0;
  Eigen::Vector3d coherence = Eigen::Vector3d::Zero();  ///< squared multiple coherence per test component
};

struct BandSelection {
  bool ok = false;           ///< false: no run of bins reached min_coherence (band = search range)
  double low_hz = 0.0;       ///< chosen band, Hz
  double high_hz = 0.0;
  std::size_t harmonics = 0; ///< whole-window harmonics in the band
  std::vector<CoherenceBin> bins;
  std::string text;          ///< one line for reports
};

/// reference_nT, test_nT: N x 3 regular, gap-free (nT); sample_period_s in s.
BandSelection select_band(const Eigen::Ref<const Readings>& reference_nT,
                          const Eigen::Ref<const Readings>& test_nT, double sample_period_s,
                          const BandSelectionSettings& settings = {});

}  // namespace magnetometer_insitu_calibration
