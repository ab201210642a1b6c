// What a window's estimate is asked for: the band, Eq. 2's weights and trend, the quality rules
// every window is held to, the estimator (plain Eq. 2 or robust) and the robust estimator's
// options. Read by WindowEstimator (window_estimator.hpp), the front door of the estimators;
// declared by calibrate_records' options and calibration_node's parameters. Frequencies in Hz,
// times in s.
#pragma once

#include <cstddef>
#include <string>

namespace magnetometer_insitu_calibration {

/// Which estimator a window gets (WindowEstimator, window_estimator.hpp, dispatches).
enum class EstimatorMethod : int {
  kPlain = 0,   ///< Eq. 2 exactly as FdWlseEstimator computes it (whole-window DFT)
  kRobust = 1,  ///< residual screening + sectioned frequency-domain M-estimation (default)
};
const char* estimator_method_name(EstimatorMethod method);  ///< "plain", "robust"
/// Parses "plain" / "robust"; throws InputError(where, ...) otherwise.
EstimatorMethod parse_estimator_method(const std::string& text, const std::string& where = "method");

/// Options of the robust estimator, of the automatic band and of the delay (robust/robust_estimator.hpp
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

}  // namespace magnetometer_insitu_calibration
