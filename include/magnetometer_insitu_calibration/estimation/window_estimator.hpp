// The estimators' front door: what a window's estimate takes and what it gives.
//
// Takes the two records of one window, reference R and test T (N x 3 readings, nT, at a regular
// sample period in s, no NaN: the pipeline fills gaps), the settings (EstimatorSettings,
// estimator_settings.hpp: the band, Eq. 2's weights, the quality rules, the method and the
// robust estimator's options) and the window's measured inputs (WindowInputs: the reference's
// noise model, a remote observatory's record on the same epochs).
//
// Gives a WindowEstimate: n of T = R n with the covariance of vec(n) and the calibration
// parameters with 95 % intervals (decomposition.hpp), the window's quality verdict, the band
// and the delay used, and what the robust steps, the errors-in-variables correction and the
// remote reference did.
//
// WindowEstimator gives each window the estimator its settings ask for (EstimatorSettings::method):
//   plain   FdWlseEstimator (fd_wlse.hpp): Eq. 2, weighted least squares of T on R over the
//           band's harmonics of the whole window, weights lambda^gamma;
//   robust  RobustFdEstimator (robust/robust_estimator.hpp): Eq. 2 as an M-estimator over the
//           harmonics of sections (cells): residual screen, iteratively reweighted least squares
//           with cell weights (robust/cell_weights.hpp: Huber) and section weights, the
//           errors-in-variables correction, the delay, sandwich and jackknife covariance.
// Both regress T on the local reference's own harmonics or, when a remote's record is given and
// predicts the reference strongly enough, on the remote's (instrumental variables,
// remote_reference.hpp). One WindowEstimator per thread: it keeps FFTW plans between windows.
#pragma once

#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "magnetometer_insitu_calibration/estimation/errors_in_variables.hpp"
#include "magnetometer_insitu_calibration/estimation/estimator_settings.hpp"
#include "magnetometer_insitu_calibration/estimation/local_event_check.hpp"
#include "magnetometer_insitu_calibration/estimation/remote_reference.hpp"
#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <functional>
#include <limits>
#include <memory>
#include <string>

namespace magnetometer_insitu_calibration {

enum class Quality : int {
  kOk = 0,
  kTooFewSamples = 1,
  kTooFewHarmonics = 2,
  kIllConditioned = 3,
  kLowCoherence = 4,
  kGaps = 5,
  kNotFinite = 6,
};
const char* quality_name(Quality q);  ///< "ok", "too_few_samples", ...

/// Result for one window of paired, regularly sampled, gap-free readings.
struct WindowEstimate {
  std::size_t samples = 0;
  double sample_period_s = 0.0;
  int harmonic_first = 0;  ///< m0
  int harmonic_last = 0;   ///< m
  Eigen::Matrix3d n = Eigen::Matrix3d::Identity();  ///< T = R n
  Matrix9d n_covariance = Matrix9d::Zero();         ///< covariance of row-major vec(n)
  /// Degrees of freedom of n_covariance: how many spectral cells its sandwich rests on, counted
  /// as cells that share it equally ((sum t)^2 / sum t^2 of the cells' expected shares t,
  /// Satterthwaite; src/core/estimation/sandwich_cells.hpp). At most the band's cells; fewer when
  /// a few strong harmonics carry the sandwich (a simulated hour's 36 cells count 24-30, a real
  /// WIC hour's 9-22; docs/validation.md, coverage). A covariance estimated from nu cells makes
  /// a quadratic form in it (chi2 against vec(n)) larger than chi2 by nu / (nu - p - 1) on average
  /// and heavier in the tail (Hotelling's T^2). The change and agreement checks use it; JSON
  /// "covariance_cells"; infinity: the covariance is taken as known (e.g. a calibration read back
  /// from a file).
  double covariance_dof = std::numeric_limits<double>::infinity();
  Eigen::Vector3d trend_nT_per_day = Eigen::Vector3d::Zero();
  Eigen::Vector3d trend_stderr_nT_per_day = Eigen::Vector3d::Zero();
  CalibrationParameters parameters;                 ///< decomposition of n with 95 % intervals
  double condition_number = 0.0;
  Eigen::Vector3d coherence = Eigen::Vector3d::Zero();
  Eigen::Vector3d residual_rms_nT = Eigen::Vector3d::Zero();
  Quality quality = Quality::kOk;
  std::string quality_text = "ok";
  // Filled by WindowEstimator (below); FdWlseEstimator leaves the defaults.
  std::string method = "plain";  ///< estimator that produced this window
  double band_low_hz = std::numeric_limits<double>::quiet_NaN();   ///< band used, Hz
  double band_high_hz = std::numeric_limits<double>::quiet_NaN();  ///< band used, Hz
  double delay_s = std::numeric_limits<double>::quiet_NaN();        ///< test minus reference, s
  double delay_ci95_s = std::numeric_limits<double>::quiet_NaN();   ///< 95 % half-width, s
  double screened_fraction = 0.0;  ///< robust: share of samples masked by the residual screen
  double downweighted_fraction = 0.0;  ///< robust: share of cell weight removed by the M-step
  /// What the errors-in-variables step did, and the reference noise model it was given (source
  /// kNone when none); errors_in_variables_text() prints both.
  ErrorsInVariables eiv = ErrorsInVariables::kNotApplicable;
  ReferenceNoiseModel eiv_noise;
  /// Weights of the sums: "lambda^gamma" (plain) or "lambda^gamma x Huber cell x section" (robust).
  std::string weights = "lambda^gamma";
  /// How the 95 % intervals were formed: "sandwich" (plain), or the robust estimator's
  /// "sandwich raised to the jackknife over K sections" / "... over 8 interleaved frequency
  /// groups" (windows of fewer than 6 sections) / "sandwich (no jackknife: ...)" when it cannot be formed.
  std::string intervals = "sandwich";
  /// The remote reference: whether n rests on it, how well it serves, the pair-only comparison.
  RemoteReference remote;
  /// Without a remote (robust estimator): n of the band's two halves compared.
  BandSplitCheck band_split;
  /// Without a remote (robust estimator): events above the band the test does not follow.
  LocalEventCheck local_events;

  /// Standard errors of the nine entries of n (row-major), sqrt of the covariance diagonal.
  Eigen::Matrix3d n_stderr() const;
  /// errors_in_variables_text(eiv, eiv_noise).
  std::string eiv_text() const { return errors_in_variables_text(eiv, eiv_noise); }
};

/// Measured inputs of one window's estimate besides the pair itself: arguments of the
/// estimators, never settings (a setting is what a user sets).
struct WindowInputs {
  /// The reference's noise for the errors-in-variables correction of the robust estimator
  /// (source kNone: no correction); ignored by plain Eq. 2. With a remote used, it serves the
  /// pair-only estimate the remote's is compared with.
  ReferenceNoiseModel reference_noise;
  /// A remote observatory's record on the window's epochs (N x 3, its own frame and units, no
  /// NaN): the instruments of the regression (remote_reference.hpp); null: none.
  const Readings* remote_nT = nullptr;
  std::string remote_name;  ///< names the remote in texts ("--remote", a topic)
};

/// Estimates n of a window (reference nT, test nT, sample period s): the estimator the window was
/// estimated with, so that a second estimate (temperature terms, response model) is made the same
/// way.
using WindowEstimateFunction =
    std::function<WindowEstimate(const Eigen::Ref<const Readings>&, const Eigen::Ref<const Readings>&, double)>;

class RobustFdEstimator;
struct RobustDiagnostics;

/// The estimator a window gets: plain Eq. 2 or robust, from settings.method; auto band and the
/// delay are applied to either (the plain method only reports the delay, it never corrects it).
/// Fills WindowEstimate::method, band_low_hz/band_high_hz and delay_s/delay_ci95_s.
class WindowEstimator {
 public:
  /// Throws InputError naming the field when a setting is impossible.
  explicit WindowEstimator(const EstimatorSettings& settings);
  ~WindowEstimator();
  /// reference_nT, test_nT: N x 3, nT, regular sample period (s), no NaN; inputs: the window's
  /// measured inputs. Throws InputError for an impossible noise model.
  WindowEstimate estimate(const Eigen::Ref<const Readings>& reference_nT, const Eigen::Ref<const Readings>& test_nT,
                          double sample_period_s, const WindowInputs& inputs = {});
  const EstimatorSettings& settings() const { return settings_; }
  /// The robust estimator's diagnostics of the last window (robust/robust_estimator.hpp; null for
  /// the plain method).
  const RobustDiagnostics* robust_diagnostics() const;

 private:
  EstimatorSettings settings_;
  std::unique_ptr<RobustFdEstimator> robust_;
};

}  // namespace magnetometer_insitu_calibration
