// Robust frequency-domain estimator of the calibration matrix for disturbed stations: the robust
// method behind WindowEstimator (window_estimator.hpp, the estimators' front door).
//
// Why Eq. 2 is fragile. A local disturbance seen by one instrument, or by both with different
// gains and directions (a vehicle on a nearby road is a moving dipole: its field falls as
// 1/r^3, so two sensors a few metres apart see it differently), enters the residual
// T - R n. Eq. 2 sums every harmonic of the whole window with its least-squares weight, so a
// few minutes of traffic or one parked car, spread over all harmonics by the DFT, bias n by
// the ratio of the disturbance's in-band power to the weak (vertical) signal's.
//
// What this estimator does (units nT, s, Hz; R in the reference frame, T in the test frame):
//  1. Residual screen (time domain). n0 from Eq. 2 on the window (on its pair averages where
//     the band and the delay's frequencies allow: pair_averages.hpp); the
//     residual e(t) = T(t) - R(t) n0 (test frame) is high-passed by subtracting a running median
//     of screen_baseline_s (slow drift, tilt and the trend are not outliers; taken over the
//     window's 10-sample block means at 1 Hz, every tenth of the window, interpolated linearly
//     between), and every sample
//     whose high-passed residual exceeds screen_threshold robust sigmas (1.4826 MAD, the centre
//     and the MAD from about 8200 evenly spaced values of the window) in any
//     component is flagged, widened by screen_margin_s. Flagged runs are replaced in BOTH
//     records by straight lines between the good samples on either side: the same linear
//     operation on R and T keeps T = R n + d (only d changes), so the masking cannot bias n;
//     since the flags depend on the residual only (independent of the field under the model),
//     they select no particular field either. Twice: the second pass uses n0 re-estimated on
//     the cleaned records. Spikes, transients and the edges of steps are removed here.
//  2. Sections. The window is cut into K sections of about section_s (>= 2 / band_low), each
//     linearly detrended and transformed. A cell is one harmonic of one section inside the
//     band; it gives X (3 reference DFT values) and Y (3 test values). With section_trend (the
//     default) each section also takes Eq. 2's trend column: the DFT of a
//     ramp, with one real coefficient per section and component, is projected out of every
//     column of its cells (section_trend.hpp). The time-domain line alone leaves the section's
//     end mismatch, which an untapered DFT spreads over all its harmonics as that ramp: a
//     drift seen by one sensor (a pier's tilt) then made the cells of a section coherent, and
//     the below-band daily variation's leakage stood in for in-band signal.
//  3. M-estimation (IRLS). With cell weights w_c and the Eq. 2 weights g_c = lambda_c^gamma,
//       A = sum w g Re(X X^H),  C = sum w g Re(X Y^H),  n = A^-1 C        (Eq. 2 with weights)
//     Residual e_c = Y_c - n^T X_c. Its scale sigma_l^2(f) is the median of |e_l|^2 / ln 2 over
//     cells of neighbouring frequency (the residual is coloured; for Gaussian noise |e|^2 is
//     exponential, whose median is ln 2 times its mean). r_c^2 = sum_l |e_l|^2 / sigma_l^2
//     (mean 3 for clean cells). Cell weight: Huber, 1 for sqrt(r^2/3) <= huber_k, else
//     huber_k / sqrt(r^2/3), when the cells make more than one frequency bin: with one bin (a
//     window under about 2 h) the scale cannot follow the colour and cells keep weight 1
//     (after two iterations cells with d > 5 get 0 in either case). Section weight: q_s =
//     median of r^2 over the section's cells / the median over sections; 1 for q <= 2, 2/q up
//     to section_rejection, then 0 (a section with raised broadband residual, e.g. a step or a
//     long transient, is dropped as a whole).
//  4. Delay (delay_estimation.hpp) from the cleaned records with n; when significant (> 2 se)
//     and correct_delay, the test record is advanced by tau over the whole window
//     (advance_record), cut into the same sections again (Y_c replaced) and step 3 is repeated,
//     so that a timing offset cannot leak into n through the imaginary part of the
//     cross-spectra (first order when the field's components are not in phase). Multiplying
//     each section's Y_c by e^{+2 pi i f tau} instead would take the section's wrapped-around
//     ends for data and bias n: a noise-free pair 2 s apart erred 0.05 % in scale and 0.022 deg
//     that way (test_delay_estimation), a 10 / 30 pT white pair -0.027 % on average.
//  5. Errors in variables (errors_in_variables.hpp): with a reference noise model among the
//     window's inputs (WindowInputs::reference_noise: a maker's figure, or the noise identified
//     from a third instrument or from the pair above the band), N_r = sum w g E|X_noise|^2 is
//     subtracted from A at every iteration; without one no correction, and the window says so
//     (WindowEstimate::eiv, ErrorsInVariables::kNoNoiseModel). Residual power is never taken for
//     reference noise.
//  6. Covariance, from the final weights:
//     a. the frequency-domain sandwich of fd_wlse.cpp over cells, Cov(vec n) =
//        c (I (x) A^-1) [sum_c s_c s_c^T] (I (x) A^-1), s_c,l = w g (Re(X conj(e_l)) + D_c n_l)
//        (the D_c term centres the score when the EIV term is used), c = 2M / (2M - 3),
//        M = sum of cell weights; it assumes independent cells and fixed weights;
//     b. the delete-one-section jackknife: n refitted without each weighted section (same
//        weights, EIV fixed point re-solved), J = (K-1)/K sum (v_s - mean)(v_s - mean)^T over
//        the K weighted sections, which sees what the sandwich cannot: transients left by the
//        screen that are coherent over a section's harmonics, steps, tilt, the data-chosen
//        weights and the uncertainty of the EIV correction;
//        When fewer than 6 sections carry weight (windows under 18 h at the default band), the
//        groups are instead 8 interleaved frequency groups (cells in frequency order, every 8th
//        in one group): n refitted without each group, which corrects the sandwich for the
//        leverage of the few strong low harmonics (section_jackknife.cpp says why interleaved);
//     c. reported: Cov = D S D, D_kk = sqrt(max(1, J_kk / S_kk)) (the sandwich raised to the
//        jackknife entry by entry, its correlations kept); the sandwich alone when the jackknife
//        cannot be formed (a group held the whole signal of a direction);
//     d. plus, with a given noise whose levels were identified from the data (the pair above
//        the band: ReferenceNoiseModel::level_covariance), the delta method's
//        J Sigma J^T of those levels through the correction (noise_level_covariance_term): the
//        jackknife re-solves with the same levels, so it cannot see their uncertainty.
//     Measured coverage and the reasoning: section_jackknife.cpp (combine_covariances) and
//     docs/validation.md (coverage of the intervals).
//
// Its parts sit in estimation/robust/ (headers: residual_screen.hpp, cell_weights.hpp here;
// the others beside their .cpp in src/core/estimation/robust/): residual_screen (step 1),
// robust_estimator.cpp (the steps in order; 2 and 4), section_cells.hpp and section_trend.hpp
// (2), section_irls with the cell weights of cell_weights.hpp (3), weighted_eiv_solve (3 and 5),
// robust_covariance and section_jackknife (6), remote_cells (the remote reference over the
// cells), halves_split (without a remote: the halves compared, their spread in the covariance).
// The plain estimator (FdWlseEstimator, fd_wlse.hpp: Eq. 2 on the whole window) is
// EstimatorSettings::method = kPlain.
#pragma once

#include "magnetometer_insitu_calibration/estimation/band_selection.hpp"
#include "magnetometer_insitu_calibration/estimation/delay_estimation.hpp"
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/estimation/robust/residual_screen.hpp"

#include <memory>
#include <vector>

namespace magnetometer_insitu_calibration {

/// What the robust estimator did in its last window, for reports and tests.
struct RobustDiagnostics {
  std::vector<char> screened;            ///< per sample: 1 = masked by the residual screen
  std::vector<double> section_weights;   ///< per section, 0..1
  std::size_t sections = 0;
  std::size_t section_samples = 0;       ///< nominal section length, samples
  std::size_t cells = 0;
  int iterations = 0;
  bool eiv_applied = false;
  Eigen::Matrix3d eiv_noise = Eigen::Matrix3d::Zero();  ///< N_r subtracted from A (nT^2 units of A)
  Eigen::Matrix3d n_uncorrected = Eigen::Matrix3d::Zero();  ///< same weights, no EIV term
  bool delay_corrected = false;
  Matrix9d covariance_sandwich = Matrix9d::Zero();   ///< step 6a, row-major vec(n)
  Matrix9d covariance_jackknife = Matrix9d::Zero();  ///< step 6b (NaN with fewer than 2 sections)
  Matrix9d covariance_noise_levels = Matrix9d::Zero();  ///< step 6d: a given noise's level uncertainty through the correction
  std::size_t jackknife_sections = 0;    ///< the jackknife's groups with weight (sections or frequency groups)
  bool jackknife_frequency_groups = false;  ///< groups are 8 interleaved frequency groups (< 6 sections)
  BandSelection band;                    ///< when auto_band
  DelayEstimate delay;
};

/// Robust estimator (steps 1-6 above). One instance per thread.
class RobustFdEstimator {
 public:
  explicit RobustFdEstimator(EstimatorSettings settings = {});
  ~RobustFdEstimator();
  RobustFdEstimator(const RobustFdEstimator&) = delete;
  RobustFdEstimator& operator=(const RobustFdEstimator&) = delete;

  /// reference_nT, test_nT: N x 3, regular sample period (s), no NaN (the pipeline fills gaps);
  /// inputs: the window's measured inputs (the reference noise model). Throws InputError for an
  /// impossible noise model.
  WindowEstimate estimate(const Eigen::Ref<const Readings>& reference_nT, const Eigen::Ref<const Readings>& test_nT,
                          double sample_period_s, const WindowInputs& inputs = {});
  const RobustDiagnostics& diagnostics() const { return diagnostics_; }
  const EstimatorSettings& settings() const { return settings_; }

 private:
  struct Impl;
  class Window;  ///< one window's estimate, step by step (robust_estimator.cpp)
  EstimatorSettings settings_;
  std::unique_ptr<Impl> impl_;
  RobustDiagnostics diagnostics_;
};

}  // namespace magnetometer_insitu_calibration
