// Errors in variables: the attenuation of a least-squares estimate of n by the reference's own
// noise, and its correction.
//
// Why there is a bias. With R = B + d_r and T = B n + d_t (B the field), every sum of Eq. 2
// is, in expectation over the noise, A = A_B + N_r and C = A_B n, where
//   N_r = sum_j g_j E[Re(w_dr(j) w_dr(j)^H)]        (g_j = lambda_j^gamma, the Eq. 2 weights)
// is the reference noise's share of the weighted reference periodogram. Hence
//   E[n_Eq2] ~ (A_B + N_r)^-1 A_B n = n - (A_B + N_r)^-1 N_r n,
// an attenuation towards zero by the in-band noise-to-signal ratio of the reference. It is
// largest at the top of the band, where the geomagnetic signal (PSD ~ f^-2) is weakest and the
// weight lambda^gamma is largest. It does not shrink with the record length: only a better
// reference, a lower band or this correction remove it.
//
// The correction (method of moments, the classical "corrected least squares"; with a known
// noise ratio it is Deming's / total least squares' estimator): subtract the expected noise
// term before solving,
//   n_c = (A - N_r)^-1 C.
// N_r needs the reference noise spectrum S_r(f) (one-sided PSD, nT^2/Hz, per reference axis),
// and for an unnormalised DFT of a section of L samples at period dt E|X_j|^2 = L S(f_j) / (2 dt).
// S_r comes from a noise model of the reference (ReferenceNoiseModel below): a white level (rms
// per sample) and a pink (1/f) level (amplitude spectral density at 1 Hz) per axis,
// S_r(f) = 2 white^2 dt + pink^2 / f, taken from the maker's figure or identified from the
// instruments themselves (a third co-located instrument, or the pair above the band:
// pipeline/reference_noise.hpp). Residual power is never taken for reference noise: the tilt of
// one pier, a local source or a response mismatch would inflate n where the signal is weak.
// The correction is refused (flag, no correction) when A - N_r is not positive definite,
// i.e. when the noise would be as large as the signal in some direction of the band.
#pragma once

#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <string>

namespace magnetometer_insitu_calibration {

/// Noise of one instrument, per axis.
struct NoiseSpectrum {
  Eigen::Vector3d white_nT = Eigen::Vector3d::Zero();            ///< rms per sample, nT
  Eigen::Vector3d pink_nT_per_sqrt_hz = Eigen::Vector3d::Zero();  ///< ASD at 1 Hz, one-sided PSD = level^2 / f

  /// One-sided PSD at f (Hz) for sample period dt (s): 2 white^2 dt + pink^2 / f, nT^2/Hz.
  Eigen::Vector3d psd(double frequency_hz, double sample_period_s) const;
  /// Expected |X_j|^2 of the unnormalised DFT of `length` samples at f: length * PSD / (2 dt), nT^2.
  Eigen::Vector3d expected_periodogram(double frequency_hz, double sample_period_s, std::size_t length) const;
  /// A positive level on at least one axis.
  bool any() const;
  /// A fluxgate maker's figure "figure_pT pT/sqrt(Hz) at 1 Hz", taken as 1/f noise below 1 Hz on
  /// every axis (what fluxgates show in the band).
  static NoiseSpectrum fluxgate_figure(double figure_pT);
};

/// Covariance, per axis of the reference's frame, of an identified noise's two levels (white^2 in
/// nT^2 rms^2 per sample, pink^2 in nT^2/Hz at 1 Hz), in that order: nT^4 and their products.
using NoiseLevelCovariance = std::array<Eigen::Matrix2d, 3>;

/// Where a reference noise model comes from.
enum class NoiseSource : int {
  kNone = 0,              ///< no model: no correction
  kMakerFigure = 1,       ///< the maker's noise figure, given by the user
  kThreeCorneredHat = 2,  ///< identified from a third co-located instrument (three-cornered hat)
  kPairAboveBand = 3,     ///< identified from the pair itself above the band
};
/// "none", "maker's figure", "three-cornered hat", "pair above the band".
const char* noise_source_name(NoiseSource source);

/// The reference's noise as the errors-in-variables correction uses it: a measured input of the
/// window's estimate (WindowInputs), never a setting.
struct ReferenceNoiseModel {
  NoiseSource source = NoiseSource::kNone;
  NoiseSpectrum spectrum;  ///< per axis of the reference's frame, at the estimation period
  /// Uncertainty of the levels when they were identified from the data; zero: taken as exact
  /// (a maker's figure). Its effect on n is added to n's covariance.
  NoiseLevelCovariance level_covariance{Eigen::Matrix2d::Zero(), Eigen::Matrix2d::Zero(), Eigen::Matrix2d::Zero()};
  std::string provider;  ///< who it was identified with: "--third", "test 'b'"; empty otherwise

  /// A source and a positive level on at least one axis: there is noise to correct for.
  bool has_noise() const;
  /// A maker's figure (no model when it has no level).
  static ReferenceNoiseModel maker_figure(const NoiseSpectrum& figure);
  /// Throws InputError("reference noise", ...) for negative or non-finite levels or a level
  /// covariance that is not symmetric positive semi-definite.
  void validate() const;
};

/// What the errors-in-variables step did in a window.
enum class ErrorsInVariables : int {
  kNotApplicable = 0,  ///< plain Eq. 2: no correction by design
  kOff = 1,            ///< switched off by the user (--eiv none, ~eiv none)
  kNoNoiseModel = 2,   ///< no reference noise model for the window: no correction
  kRefused = 3,        ///< the model's noise was as large as the signal in some direction: none
  kApplied = 4,        ///< n corrected for the model's noise
  kRemoteReference = 5,  ///< n from a remote reference: the reference's noise does not bias it
};
/// "not_applicable", "off", "no_noise_model", "refused", "applied", "remote_reference".
const char* errors_in_variables_name(ErrorsInVariables applied);
/// One line for reports and diagnostics: what was applied and, when applied, the noise model
/// (source, provider and levels), e.g. "applied: reference noise from the pair above the band,
/// white 20.4/18.1/22.0 pT rms, 1/f 2.95/3.1/2.2 pT/sqrt(Hz) at 1 Hz (x/y/z)".
std::string errors_in_variables_text(ErrorsInVariables applied, const ReferenceNoiseModel& noise);

/// n_c = (A - N)^-1 C for the field block (the first three regressors; N is 3 x 3 and is
/// subtracted from the top-left block of A, p x p). Returns false and leaves `solution`
/// untouched when A - N is not positive definite (noise as large as the signal).
bool corrected_solve(const Eigen::MatrixXd& a, const Eigen::Matrix3d& noise, const Eigen::MatrixXd& c,
                     Eigen::MatrixXd& solution, Eigen::MatrixXd* corrected_inverse = nullptr);

/// First-order attenuation of Eq. 2 by reference noise N for the weighted signal matrix A_B:
/// (A_B + N)^-1 N (3 x 3): E[n_Eq2] ~ n - attenuation * n. For planning and for the tests.
Eigen::Matrix3d eiv_attenuation(const Eigen::Matrix3d& signal, const Eigen::Matrix3d& noise);

}  // namespace magnetometer_insitu_calibration
