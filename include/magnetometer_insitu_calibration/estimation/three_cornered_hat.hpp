// Noise of each of three co-located instruments from their pairwise residuals (the
// three-cornered hat of clock metrology), for the errors-in-variables correction with
// IDENTIFIED noise (errors_in_variables.hpp).
//
// For instruments a, b, c recording the same field, the residual of the pair (a, b),
// e_ab = T_b - T_a n_ab (n_ab from Eq. 2, T_a as the reference), has the one-sided PSD
// S_e,ab = S_b + n_ab^T S_a n_ab ~ S_a + S_b per axis when the axes are nearly aligned
// (|n - I| << 1) and the noises are independent. Three pairs give three equations per axis and
// frequency, solved exactly:
//   S_a = (S_ab + S_ac - S_bc) / 2,  S_b = (S_ab + S_bc - S_ac) / 2,  S_c = (S_ac + S_bc - S_ab) / 2.
// What the three instruments share (the field, a disturbance seen by all) cancels; a
// disturbance seen by one instrument only is attributed to that instrument's "noise"; noise
// correlated between two instruments (a common power supply) makes the third's estimate
// too large and theirs too small, possibly negative (reported as is: a negative estimate means
// the independence assumption fails). The estimates are periodogram averages: relative scatter
// about 1 / sqrt(harmonics in the bin).
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <Eigen/Core>

#include <array>
#include <vector>

namespace magnetometer_insitu_calibration {

enum class ThreeCorneredHatMethod {
  /// Default. From the 3 x 3 cross-spectral matrices S_uv of the records (u, v = a, b, c; bin
  /// sums of U^H V): N_a = diag(S_aa - S_ac S_bc^-1 S_ba), and likewise for b and c. Any 3 x 3
  /// gain and mixing between the records cancels, and the field to first order in the noises.
  kCrossSpectral,
  /// The pairwise residual PSDs combined as above (S_a = (S_ab + S_ac - S_bc) / 2). A noisy
  /// reference attenuates each pair's n, which leaves (attenuation x field) in the residuals:
  /// with a steep field spectrum that dominates the lowest bins (2.3x the truth measured in the
  /// lowest of 4 bins over 0.0002-0.01 Hz, reference 1/f 20 pT/sqrt(Hz) at 1 Hz, test_reference_noise).
  kResidual,
};

struct ThreeCorneredHatSettings {
  double band_low_hz = 0.0002;  ///< Hz
  double band_high_hz = 0.01;   ///< Hz
  int bins = 4;                 ///< log-spaced frequency bins over the band (>= 1)
  ThreeCorneredHatMethod method = ThreeCorneredHatMethod::kCrossSpectral;
  /// When not empty: the bins' edges, Hz, strictly ascending, at least two (bin k is
  /// [edges[k], edges[k + 1])); band_low_hz, band_high_hz and bins are then not used.
  std::vector<double> bin_edges_hz;
};

struct ThreeCorneredHatResult {
  std::vector<double> bin_low_hz, bin_high_hz;  ///< edges of each bin, Hz
  /// psd_nT2_per_hz[instrument][bin]: one-sided PSD per axis of that instrument's frame,
  /// nT^2/Hz (the mean over the bin's harmonics); instrument 0, 1, 2 = a, b, c.
  std::array<std::vector<Eigen::Vector3d>, 3> psd_nT2_per_hz;
  /// kCrossSpectral: the standard deviation of each psd_nT2_per_hz value, same layout and units,
  /// from the scatter of its terms over the bin's harmonics; empty with kResidual.
  std::array<std::vector<Eigen::Vector3d>, 3> psd_sd_nT2_per_hz;
  /// kCrossSpectral: the part of each estimate's scatter that does not shrink with the
  /// instrument's own noise, as a PSD (nT^2/Hz, same layout): sqrt(N_y' N_z' / 2), the other
  /// two instruments' noise as seen in its residuals. Per harmonic the estimate's variance is
  /// about (N + floor)^2 (N its own PSD): a quiet instrument beside noisy ones scatters by the
  /// floor. fit_hat_instrument weights the bins by it; empty with kResidual.
  std::array<std::vector<Eigen::Vector3d>, 3> psd_floor_nT2_per_hz;
  /// Pairwise residual PSDs (ab, ac, bc), same layout: the inputs of the kResidual hat (empty
  /// with kCrossSpectral, which needs no pairwise fit).
  std::array<std::vector<Eigen::Vector3d>, 3> pair_psd_nT2_per_hz;
};

/// a, b, c: N x 3 each (nT, regular sample period dt s, no NaN, same epochs). Throws
/// InputError("three_cornered_hat", ...) for unequal lengths, a bad band or too few samples.
ThreeCorneredHatResult three_cornered_hat(const Readings& a, const Readings& b, const Readings& c, double dt,
                                          const ThreeCorneredHatSettings& settings = {});

}  // namespace magnetometer_insitu_calibration
