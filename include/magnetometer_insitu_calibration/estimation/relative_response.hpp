// Relative frequency response of the test instrument: gain and phase of T against the reference
// mapped through the estimated matrix, R n, per test component, in log-spaced frequency bands.
//
// Eq. 2 assumes T = R n + noise at every frequency: the two instruments differ only by a constant
// matrix. Two instruments with different anti-alias filters or time stamping differ by a relative
// response H_k(f) per component k that is not flat. This estimates it, so that an engineer can
// see where it is flat (the band where Eq. 2 holds) and where it is not.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"
#include "magnetometer_insitu_calibration/estimation/errors_in_variables.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace magnetometer_insitu_calibration {

struct RelativeResponseSettings {
  double low_hz = 0.0001;        ///< lowest band edge, Hz
  double high_hz = 0.1;          ///< highest band edge, Hz (clipped to 0.9 x Nyquist)
  int bands_per_decade = 10;     ///< log-spaced band edges
  std::size_t min_harmonics = 6; ///< a band with fewer DFT harmonics is not reported
  /// The reference's noise when it is identified (a maker's figure, a three-cornered hat; zero:
  /// not identified). Its expected share of each band's |P|^2 (P = R n: sum_i n_ik^2 S_r,i) is
  /// then subtracted before the gain is solved, as errors_in_variables.hpp does for n: at the top
  /// of the range, where the geomagnetic signal is weak, the reference's noise otherwise
  /// attenuates the gain and a fitted corner comes out low (response_model.hpp).
  NoiseSpectrum reference_noise;

  /// Throws InputError naming the field when a value is impossible.
  void validate() const;
};

/// One band. Gain and phase of the test component k against (R n)_k, estimated over the band's
/// harmonics j as H_k = sum_j conj(P_kj) T_kj / sum_j |P_kj|^2 (P = DFT of R n). Phase in degrees,
/// negative when the test record lags (a delay tau gives -360 f tau). Intervals: 95 % half-widths
/// from the band's own residual T - H P (Student t with 2 (M - 2) degrees of freedom, M harmonics:
/// student_t_two_sided_quantile; a standard error is the half-width over it),
/// linearised; n's own uncertainty is not included (it is fitted over the calibration band, where
/// H is 1 by construction). With settings.reference_noise, H is corrected for the reference's
/// noise (errors in variables); a band where that noise would be as large as |P|^2 keeps the
/// uncorrected H.
struct ResponseBand {
  double frequency_hz = 0.0;     ///< |P|^2-weighted mean frequency of the band's harmonics, Hz
  double low_hz = 0.0, high_hz = 0.0;  ///< band edges, Hz
  std::size_t harmonics = 0;     ///< M
  Eigen::Vector3d gain = Eigen::Vector3d::Ones();
  Eigen::Vector3d gain_ci95 = Eigen::Vector3d::Zero();
  Eigen::Vector3d phase_deg = Eigen::Vector3d::Zero();
  Eigen::Vector3d phase_ci95_deg = Eigen::Vector3d::Zero();
};

/// reference and test: N x 3, nT, regular sample period period_s, no NaN; n: T = R n. Both
/// records are first-differenced (a filter applied alike to both leaves H unchanged and whitens
/// the steep geomagnetic spectrum, so that low-frequency power does not leak into higher bands)
/// and tapered by a 10 % split-cosine bell; the N - 1 differences are transformed with one zero
/// appended (N: a fast FFT length where N - 1 seldom is). Returns the bands, lowest first; empty when no band
/// has min_harmonics harmonics.
/// With `remote` (a remote observatory on the same epochs, any frame and units: remote_reference.hpp)
/// H is an instrumental-variable estimate: per band and component the remote's prediction of P,
/// Q = Z b (b by least squares of P on the remote's three DFTs Z over the band), is the
/// instrument, H = (Q^H X)^-1 Q^H T with X = [P, P u], and its variance the sandwich
/// (Q^H X)^-1 Q^H Q (X^H Q)^-1 sigma^2. The reference's noise then does not attenuate H, and no
/// correction for it is made.
std::vector<ResponseBand> relative_response(const Readings& reference, const Readings& test,
                                            const Eigen::Matrix3d& n, double period_s,
                                            const RelativeResponseSettings& settings = {},
                                            const Readings* remote = nullptr);

/// Summary for diagnostics: the largest |gain - 1| over the bands whose frequency lies in
/// [low_hz, high_hz] (NaN when none) with that band's 95 % half-width (a departure inside it is
/// not significant), and the group delay, s, of the phase against angular
/// frequency over those bands (weighted straight-line fit through the origin, per component,
/// averaged; positive when the test lags).
struct ResponseSummary {
  double max_gain_departure = 0.0;
  double max_gain_departure_ci95 = 0.0;
  double group_delay_s = 0.0;
  std::size_t bands = 0;
};
ResponseSummary summarise_response(const std::vector<ResponseBand>& bands, double low_hz, double high_hz);

}  // namespace magnetometer_insitu_calibration
