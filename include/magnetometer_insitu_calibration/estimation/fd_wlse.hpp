// Frequency-domain weighted least squares estimator (FD-WLSE) of the calibration matrix,
// Eq. 2 of Marusenkov et al. after Nielsen (2005, J. Time Ser. Anal. 26, 279-304).
#pragma once

#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "magnetometer_insitu_calibration/estimation/errors_in_variables.hpp"
#include "magnetometer_insitu_calibration/estimation/local_event_check.hpp"
#include "magnetometer_insitu_calibration/estimation/remote_reference.hpp"
#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <Eigen/Core>

#include <array>
#include <complex>
#include <cstddef>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <string>

namespace magnetometer_insitu_calibration {

/// FFTW's planner is not thread-safe: every FFTW plan made or destroyed in the core takes this lock.
std::mutex& fftw_planner_lock();

/// Which estimator a window gets (see robust_estimator.hpp; WindowEstimator dispatches).
enum class EstimatorMethod : int {
  kPlain = 0,   ///< Eq. 2 exactly as FdWlseEstimator computes it (whole-window DFT)
  kRobust = 1,  ///< residual screening + sectioned frequency-domain M-estimation (default)
};
const char* estimator_method_name(EstimatorMethod method);  ///< "plain", "robust"
/// Parses "plain" / "robust"; throws InputError(where, ...) otherwise.
EstimatorMethod parse_estimator_method(const std::string& text, const std::string& where = "method");

/// Options of the robust estimator, of the automatic band and of the delay (robust_estimator.hpp
/// explains each step). Ignored by FdWlseEstimator itself.
struct RobustSettings {
  // Time-domain screening of the residual T - R n0 (n0: Eq. 2 on the window).
  bool screen = true;
  double screen_threshold = 6.0;     ///< multiple of the robust (MAD) sigma of the high-passed residual
  double screen_baseline_s = 3600.0; ///< s, running-median baseline removed first (plateaus < half of it are flagged)
  double screen_margin_s = 30.0;     ///< s, flagged spans are widened by this on each side
  // Sectioned M-estimation.
  double section_s = 10800.0;        ///< s, section length (shortened for short windows, >= 2 / band_low)
  bool section_trend = true;         ///< Eq. 2's trend column per section (its ramp projected out of the cells)
  double huber_k = 2.0;              ///< Huber constant on the standardised cell residual (sigma units)
  double section_rejection = 4.0;    ///< section weight 0 when its robust residual z exceeds this
  int iterations = 8;                ///< IRLS iterations (stops earlier when converged)
  // Automatic band (band_selection.hpp): within [band_search_low_hz, band_search_high_hz].
  bool auto_band = false;
  double band_search_low_hz = 0.0001;
  double band_search_high_hz = 0.05;
  double min_band_coherence = 0.9;   ///< squared multiple coherence every component must reach
  // Delay (delay_estimation.hpp), test relative to reference.
  bool estimate_delay = true;
  bool correct_delay = true;         ///< remove a significant delay by a phase shift before fitting
  double delay_max_hz = 0.1;         ///< highest frequency used for the delay, Hz
  /// Correct n for the reference's noise when the window comes with a noise model
  /// (WindowInputs::reference_noise; errors_in_variables.hpp). Off: never.
  bool errors_in_variables = true;

  /// Throws InputError naming the field when a value is impossible.
  void validate() const;
};

struct EstimatorSettings {
  double band_low_hz = 0.0002;   ///< lower band edge: harmonics below are not summed (m0)
  double band_high_hz = 0.01;    ///< upper band edge (m)
  double gamma = 1.0;            ///< weights lambda_j^gamma
  bool trend = true;             ///< add a linear-trend column to the reference
  // Quality rules: a window that breaks one is flagged, never silently accepted.
  std::size_t min_harmonics = 16;      ///< fewer harmonics in the band: TooFewHarmonics
  double max_condition_number = 1e4;   ///< of the 3x3 reference block of A: IllConditioned
  double min_coherence = 0.5;          ///< any component below: LowCoherence
  EstimatorMethod method = EstimatorMethod::kRobust;  ///< used by WindowEstimator / the pipeline
  RobustSettings robust;                               ///< options of the robust method

  /// How many DFT harmonics j / window_s (window_s in s) fall inside [band_low_hz, band_high_hz]:
  /// a window with fewer than min_harmonics is always flagged TooFewHarmonics.
  double band_harmonics(double window_s) const;
  /// Why windows of `window_s` s are too short for the band: "holds only H DFT harmonics in the
  /// band L-U Hz, fewer than the M a window needs (every window would be flagged); windows of W s
  /// or longer hold them". Empty when band_harmonics(window_s) >= min_harmonics.
  std::string too_few_harmonics(double window_s) const;
  /// A window length, s, that holds at least min_harmonics harmonics in the band (the W above).
  double harmonics_window_s() const;

  /// Why the band cannot be estimated on records of estimation period `period_s` (s): its top
  /// above their Nyquist frequency 0.5 / period_s (minute data: 0.0083 Hz, under the paper's
  /// 0.01 Hz), where the harmonics are those of the band below folded back. Empty when it can.
  /// calibrate_records and calibration_node refuse such a band with this text.
  std::string band_above_nyquist(double period_s) const;

  /// Throws InputError naming the field when a value is impossible.
  void validate() const;
};

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
  // Filled by WindowEstimator (robust_estimator.hpp); FdWlseEstimator leaves the defaults.
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

/// Quality figures and rules shared by every estimator: sets e.condition_number from the 3x3
/// field block of A (strongest / weakest in-band signal direction), then e.quality and
/// e.quality_text from `harmonics` (described as `harmonics_noun`, e.g. "harmonics"),
/// e.condition_number and e.coherence against the settings' rules, first failure wins.
void apply_quality_rules(WindowEstimate& e, const Eigen::Matrix3d& field_block_of_a, long harmonics,
                         const char* harmonics_noun, const EstimatorSettings& settings);

/// Estimates n from reference R and test T (N x 3, nT, regular sample period, no NaN).
/// Holds FFTW plans and buffers; reuses them while N stays the same. One instance per thread.
class FdWlseEstimator {
 public:
  explicit FdWlseEstimator(EstimatorSettings settings = {});
  ~FdWlseEstimator();
  FdWlseEstimator(const FdWlseEstimator&) = delete;
  FdWlseEstimator& operator=(const FdWlseEstimator&) = delete;

  /// inputs: the window's remote (remote_reference.hpp; its reference noise is not used here).
  WindowEstimate estimate(const Eigen::Ref<const Readings>& reference_nT,
                          const Eigen::Ref<const Readings>& test_nT, double sample_period_s,
                          const WindowInputs& inputs = {});

  /// Bins j = 0 .. N/2 (FFTW's convention, unnormalised) of column `column` of the last
  /// estimate()'s whole-window transform: 0-2 the reference minus its mean, 3-5 the test minus
  /// its mean (nT). nullptr when the last estimate() transformed nothing (bad input). Valid
  /// until the next call.
  const std::complex<double>* last_spectrum(int column) const;

  const EstimatorSettings& settings() const { return settings_; }

  struct Workspace;  ///< FFTW plan and buffers (fd_wlse.cpp)

 private:
  EstimatorSettings settings_;
  std::unique_ptr<Workspace> workspace_;
};

}  // namespace magnetometer_insitu_calibration
