// Relative delay between the test and the reference instrument from the phase of their
// cross-spectrum.
//
// If the test instrument samples the field tau seconds late, T(t) = R(t - tau) n, and with the
// DFT convention X(f) = sum x(t) e^{-2 pi i f t} its spectrum is T(f) = R(f) n e^{-2 pi i f tau}.
// With the prediction P(f) = n^T R(f) (n from the calibration, any accuracy better than ~1 %
// will do: the phase does not depend on the gain), the cross-spectrum P^* T has the phase
// phi(f) = -2 pi f tau, a straight line through the origin. The estimate is its weighted
// least-squares slope over frequency bins of G harmonics:
//   tau = -sum_b w_b f_b phi_b / (2 pi sum_b w_b f_b^2),
//   w_b = 1 / var(phi_b),  var(phi_b) = (1 - coh_b) / (2 G_b coh_b)   (coh_b: squared coherence)
// (the classical variance of a cross-spectral phase averaged over G_b independent DFT values).
// The standard error is sqrt(1 / sum_b w_b (2 pi f_b)^2), scaled up by sqrt(chi^2 / dof) of the
// fit when the scatter of the phases exceeds their stated variance (never scaled down), so the
// interval stays honest when neighbouring harmonics are correlated or the noise is not stationary.
// The records are first-differenced (flattens the red geomagnetic spectrum, so that low
// frequencies do not leak into high ones), detrended, padded with one zero to the record's
// length N and Hann-tapered over N samples, identically for both (harmonic j at j / (N dt)).
// These steps are applied to the records' whole-window DFTs in the frequency domain, exactly
// (src/core/estimation/delay_spectra.hpp): the robust estimator passes Eq. 2's transforms of
// the same records, so the delay costs no transform of its own.
// Delays well below one sample are resolved: the paper requires synchronisation better than
// 10 ms; at 0.05 Hz a delay of 1 ms is a phase of 3e-4 rad.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <string>

namespace magnetometer_insitu_calibration {

struct DelaySettings {
  double low_hz = 0.001;       ///< lowest frequency used, Hz
  double high_hz = 0.1;        ///< highest frequency used, Hz (capped below Nyquist)
  std::size_t bin_harmonics = 16;  ///< harmonics G per phase bin
  double min_coherence = 0.5;  ///< bins below (squared coherence) are not used

  void validate() const;  ///< throws InputError naming the field
};

struct DelayEstimate {
  bool ok = false;             ///< false: too few usable bins; values NaN
  double delay_s = 0.0;        ///< test minus reference: > 0 when the test sees the field later, s
  double stderr_s = 0.0;       ///< standard error, s
  double ci95_s = 0.0;         ///< 95 % half-width, s
  std::size_t bins = 0;        ///< phase bins used
  double chi2_per_dof = 0.0;   ///< scatter of the phases about the line / their stated variance
  std::string text;
};

/// reference_nT, test_nT: N x 3 regular, gap-free (nT); n: T = R n (3 x 3); dt in s.
DelayEstimate estimate_delay(const Eigen::Ref<const Readings>& reference_nT,
                             const Eigen::Ref<const Readings>& test_nT, const Eigen::Matrix3d& n,
                             double sample_period_s, const DelaySettings& settings = {});

/// The record advanced by advance_s (x(t + advance_s), s; may be a fraction of a sample): each
/// column's line through its first and last samples is taken out (no wrap-around step), the rest
/// is shifted by the phase e^{+2 pi i f advance_s} over the whole window's DFT, and the line is
/// put back at t + advance_s. Used to remove a test instrument's delay BEFORE a record is cut
/// into sections: a phase shift of each section's own DFT treats the section as periodic and
/// takes the |advance| / dt samples at its ends for their wrap-around, an error in every section
/// (record_shift.cpp). Only the first or last |advance_s| of the window wrap around here.
Readings advance_record(const Eigen::Ref<const Readings>& x, double sample_period_s, double advance_s);

}  // namespace magnetometer_insitu_calibration
