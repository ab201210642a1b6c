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
// Two ways to know S_r:
//  - given: a white level (rms per sample) and a pink (1/f) level (amplitude spectral density at
//    1 Hz) per axis, from the maker's figure or a noise test: S_r(f) = 2 white^2 dt + pink^2 / f;
//  - from the residual with a known ratio rho = S_r / S_t of the two instruments' noise PSDs
//    (e.g. 1 for two instruments of the same type, as in the paper): the residual e = T - R n
//    has the spectrum S_t + n^T S_r n, which for axes that are nearly aligned (|n - I| << 1, the
//    in-situ case) is S_t,k + S_r,k per axis, so S_r,k = rho / (1 + rho) S_e,k. The robust
//    estimator takes E|X_noise|^2 of each cell from that cell's own residual power, capped at
//    9 times the robust (median) scale of its frequency bin and divided by 1 - e^-9, so that an
//    outlier cannot inflate it much while clean cells keep their own level (a per-bin level
//    misses the 1/f change of the noise inside a bin, and a median has twice the variance of
//    a mean). This is circular in n (the residual depends on n), so the robust estimator
//    iterates it to its fixed point, the Deming solution; the uncertainty of the estimated
//    noise enters the intervals through the robust estimator's section jackknife.
// The correction is refused (flag, no correction) when A - N_r is not positive definite,
// i.e. when the noise would be as large as the signal in some direction of the band.
#pragma once

#include <Eigen/Core>

#include <cstddef>

namespace magnetometer_insitu_calibration {

/// Noise of one instrument, per axis.
struct NoiseSpectrum {
  Eigen::Vector3d white_nT = Eigen::Vector3d::Zero();            ///< rms per sample, nT
  Eigen::Vector3d pink_nT_per_sqrt_hz = Eigen::Vector3d::Zero();  ///< ASD at 1 Hz, one-sided PSD = level^2 / f

  /// One-sided PSD at f (Hz) for sample period dt (s): 2 white^2 dt + pink^2 / f, nT^2/Hz.
  Eigen::Vector3d psd(double frequency_hz, double sample_period_s) const;
  /// Expected |X_j|^2 of the unnormalised DFT of `length` samples at f: length * PSD / (2 dt), nT^2.
  Eigen::Vector3d expected_periodogram(double frequency_hz, double sample_period_s, std::size_t length) const;
};

/// Share of the residual PSD that belongs to the reference, rho / (1 + rho) for rho = S_r / S_t.
double reference_share_of_residual(double noise_ratio);

/// n_c = (A - N)^-1 C for the field block (the first three regressors; N is 3 x 3 and is
/// subtracted from the top-left block of A, p x p). Returns false and leaves `solution`
/// untouched when A - N is not positive definite (noise as large as the signal).
bool corrected_solve(const Eigen::MatrixXd& a, const Eigen::Matrix3d& noise, const Eigen::MatrixXd& c,
                     Eigen::MatrixXd& solution, Eigen::MatrixXd* corrected_inverse = nullptr);

/// First-order attenuation of Eq. 2 by reference noise N for the weighted signal matrix A_B:
/// (A_B + N)^-1 N (3 x 3): E[n_Eq2] ~ n - attenuation * n. For planning and for the tests.
Eigen::Matrix3d eiv_attenuation(const Eigen::Matrix3d& signal, const Eigen::Matrix3d& noise);

}  // namespace magnetometer_insitu_calibration
