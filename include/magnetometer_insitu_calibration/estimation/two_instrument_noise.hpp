// The reference's noise from the pair itself, above the calibration band: the part of
// the reference's auto-spectrum that is not coherent with the test through the calibration.
//
// With row spectra R_j, T_j (1 x 3) of harmonic j and a test that records the reference's field
// through n and a diagonal response H(f) (T = (R_field n) diag(H) + noise), the cross-spectral
// sums over a bin are S_RT = P n diag(H) and S_RR = P + N_r, P the field's part. So
//   N_r = diag(S_RR - S_RT diag(H)^-1 n^-1)
// (Holcomb's two-instrument method with a known relative transfer function). An error dn in n or
// dH in H leaves P (dn, dH) in the estimate: usable only where the field is not much stronger
// than the noise, i.e. above the band, not inside it, where n is estimated. The estimate per bin
// is then extrapolated into the band by a white + 1/f fit (reference_noise.hpp). What the
// estimate assumes: the two noises are independent, the field is the same at both sensors, and
// n, H hold above the band; a disturbance seen by the reference only counts as its noise.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// The test's response relative to the reference, per component k (0 = x): a delay (s, test
/// late) and a one-pole low-pass of corner corner_hz(k) (infinity: none), H_k(f) =
/// e^{-2 pi i f delay} / (1 + i f / fc_k).
struct RelativeTransfer {
  double delay_s = 0.0;
  Eigen::Vector3d corner_hz = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
};

struct TwoInstrumentNoise {
  std::vector<double> bin_low_hz, bin_high_hz;   ///< Hz
  std::vector<Eigen::Vector3d> reference_psd;    ///< one-sided PSD per axis, nT^2/Hz
  /// Standard deviation of each reference_psd value, nT^2/Hz: from the scatter over the bin's
  /// harmonics of each one's term (the field's part included), for the Hann taper's correlation
  /// of neighbouring harmonics.
  std::vector<Eigen::Vector3d> reference_psd_sd;
  std::vector<Eigen::Vector3d> coherent_psd;     ///< the field's part of the reference's PSD, nT^2/Hz
  std::vector<int> harmonics;                    ///< per bin
};

/// reference, test: N x 3 (nT, regular period dt s, no NaN, same epochs); n the calibration
/// (T = R n), transfer the test's relative response. `bins` log-spaced bins over [low, high) Hz.
/// Each column is detrended and Hann-tapered before its DFT (the field's leakage is coherent and
/// cancels; the taper keeps the reference's own low-frequency noise out of the bins). Throws
/// InputError("two_instrument_noise", ...) for unequal lengths, a bad band or a bin with fewer
/// than 8 harmonics.
TwoInstrumentNoise two_instrument_noise(const Readings& reference, const Readings& test, double dt,
                                        const Eigen::Matrix3d& n, const RelativeTransfer& transfer, double low_hz,
                                        double high_hz, int bins);

/// The six columns' DFTs of a pair (reference x, y, z, then the test's; N x 3 each, nT, regular
/// period dt s, no NaN), each detrended and Hann-tapered: what two_instrument_noise and
/// fit_transfer_from_phase read, computed once for both. Throws InputError("two_instrument_noise",
/// ...) for unequal lengths or dt <= 0.
struct PairSpectra {
  std::array<Eigen::VectorXcd, 6> columns;
  std::size_t length = 0;  ///< samples
  double dt = 0.0;         ///< s
};
PairSpectra pair_spectra(const Readings& reference, const Readings& test, double dt);

/// The same on spectra already taken.
TwoInstrumentNoise two_instrument_noise(const PairSpectra& pair, const Eigen::Matrix3d& n,
                                        const RelativeTransfer& transfer, double low_hz, double high_hz, int bins);

/// The test's roll-off above the band, from the phase of the pair's cross-spectrum alone.
///
/// A test whose gain falls across the bins (a one-pole low-pass of corner fc a few times above
/// them: gain 1 / sqrt(1 + (f/fc)^2), 0.89 at fc / 2) gives N_r above a field P (1 - |H|) too
/// large, P tens of times the noise there: the gain alone cannot tell a falling test gain from
/// reference noise. The phase can: the reference's noise adds to |R n|^2, never to
///   C_k = sum_j conj((R_j n)_k) T_jk e^{2 pi i f_j d0} = H_k(f) e^{2 pi i f d0} sum_j |(F_j n)_k|^2 + zero-mean terms,
/// whose phase is that of H_k relative to the start delay d0. Per bin and test component k the
/// phase of C_k, at the bin's |R n| |T|-weighted mean frequency, is fitted by weighted least
/// squares (Levenberg-Marquardt) as
///   phi_k(f) = -2 pi f d - atan(f q)      d: delay less d0, s;  q = 1 / fc >= 0, s
/// one corner for the three components (the test's electronics filter each alike), each value
/// weighted by its phase variance (1 - g^2) / (2 g^2 M_eff) (g^2 the bin's coherence, M_eff its
/// harmonics over 35/18 for the Hann taper), the covariance scaled by chi^2 / dof when that
/// exceeds 1. The phase tells a corner from a delay only by atan's curvature, weak in bins well
/// below the corner: a corner counts where chi^2 of the delay alone less the fit's (over the
/// fit's chi^2 / dof when above 1) is at least kPhaseCornerChi2 (a 1-pole at 0.5 Hz: about 11
/// on 2 days at 1 Hz, test_two_instrument_noise). The transfer then holds d0 + d and the corner
/// on every component, else d0 and none (the lag of a corner that does not count stays in the
/// delay, as in the response model).
struct PhaseTransferFit {
  bool fitted = false;              ///< false: fewer than 4 values with signal, or a step not finite
  RelativeTransfer transfer;        ///< start delay, or the fitted delay and the corner that counts
  double inverse_corner_s = 0.0;    ///< fitted q = 1 / fc, s
  double inverse_corner_se_s = 0.0; ///< its standard error, s (infinite at q = 0)
  double chi2_per_dof = 0.0;
  double curvature_chi2 = 0.0;      ///< chi^2 of the delay alone less the fit's (scaled as above)
  bool any_corner() const;
  std::string text;  ///< "" when no corner counts, else the corner, its chi^2 drop and the delay
};

/// The drop in chi^2 from the delay alone to the fit that counts as curvature: the 99.73 % point
/// (three sigma) of chi^2 with one degree of freedom.
constexpr double kPhaseCornerChi2 = 9.0;

/// The fit above on the bins of two_instrument_noise (same arguments; start_delay_s d0 the
/// response model's delay, test late). Throws as two_instrument_noise does.
PhaseTransferFit fit_transfer_from_phase(const Readings& reference, const Readings& test, double dt,
                                         const Eigen::Matrix3d& n, double start_delay_s, double low_hz,
                                         double high_hz, int bins);
PhaseTransferFit fit_transfer_from_phase(const PairSpectra& pair, const Eigen::Matrix3d& n, double start_delay_s,
                                         double low_hz, double high_hz, int bins);

}  // namespace magnetometer_insitu_calibration
