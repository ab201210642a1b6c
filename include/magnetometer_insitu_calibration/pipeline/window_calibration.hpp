// One window of a reference and a test record, calibrated: the per-window stage that both
// calibrate_records (over a record's windows, calibration_pipeline.hpp) and calibration_node
// (over its live sliding windows) call, so that the two give the same result for the same
// window.
//
// Given a window of the pair on the estimation grid and the measured inputs that come with it,
// WindowCalibrator::calibrate():
//  1. puts the window on its regular grid and fills its gaps in both records at the same epochs
//     (regularize_and_fill: straight lines, which keep T = R n); epochs missing at its edges
//     are counted, not filled;
//     The remote's samples (when the window has a remote; on the estimation epochs already,
//     side_stream.hpp) take one row per epoch, its gaps bridged by straight lines (still a valid instrument: only its strength suffers, which the
//     estimator measures); a remote with samples at fewer than half the epochs is refused;
//  2. chooses the reference noise model of the errors-in-variables correction (robust method,
//     correction on): the maker's figure when one is set; else the three-cornered hat with the
//     window's third instrument; else the pair itself above the band, identified after a first
//     estimate (pipeline/reference_noise.hpp); the window's `reference_noise` says which and why;
//  3. estimates n (WindowEstimator: plain Eq. 2 or the robust estimator; on the remote's
//     instruments when it serves, estimation/remote_reference.hpp), the response model
//     (n through a modelled filter of the test), the temperature terms (when the window has a
//     varying sensor temperature) and the relative response;
//  4. the offset of the test against the reference at the window's end;
//  4b. with a scalar magnetometer, the reference's scale along the field (scalar_window.hpp);
//  5. the gap rule: a window with more than max_filled_fraction of its epochs interpolated or
//     missing at its edges, or with a gap longer than max_fill_s, is flagged Quality::kGaps
//     (the cause reported even when the shortened window also failed an estimator's rule);
//  6. each parameter's verdict against the tolerances and, when one is undecided, how the
//     intervals narrow with length, from the window's halves and quarters (tolerance_verdicts.hpp).
// Units: nT, UNIX seconds, Hz; each instrument in its own frame.
#pragma once

#include "magnetometer_insitu_calibration/estimation/relative_response.hpp"
#include "magnetometer_insitu_calibration/estimation/response_model.hpp"
#include "magnetometer_insitu_calibration/estimation/window_estimator.hpp"
#include "magnetometer_insitu_calibration/estimation/temperature_regression.hpp"
#include "magnetometer_insitu_calibration/pipeline/reference_noise.hpp"
#include "magnetometer_insitu_calibration/pipeline/scalar_window.hpp"
#include "magnetometer_insitu_calibration/pipeline/tolerance_verdicts.hpp"
#include "magnetometer_insitu_calibration/preprocessing/gap_filling.hpp"
#include "magnetometer_insitu_calibration/preprocessing/time_alignment.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// What a user sets for every window (calibrate_records' options, calibration_node's
/// parameters); measured inputs travel with the window (WindowRecords).
struct WindowCalibrationSettings {
  EstimatorSettings estimator;
  /// The reference's noise as its data sheet or a noise test states it (per axis: white, nT rms
  /// per sample at the estimation period; 1/f, nT/sqrt(Hz) at 1 Hz); none: identified from the
  /// data. calibrate_records --reference-noise-pT and ~reference_noise_pT give a fluxgate's
  /// figure (NoiseSpectrum::fluxgate_figure). Used by the robust method's errors-in-variables
  /// correction instead of a noise identified from the data.
  NoiseSpectrum reference_noise_figure;
  /// Identify the reference's noise from the window's third instrument (three-cornered hat)
  /// when the window has one and no figure is set.
  bool three_cornered_hat = true;
  /// Identify the reference's noise from the pair above the band when neither a figure nor the
  /// hat gives one.
  bool pair_noise = true;
  /// Fit a delay and a 1-pole low-pass per test component to the relative response and, where a
  /// corner is significant, estimate n through it (response_model.hpp). Robust method only.
  bool response_model = true;
  ResponseModelSettings model;
  bool relative_response = true;  ///< estimate the window's relative frequency response
  RelativeResponseSettings response;
  /// Temperature terms: min_range_C is used as given; band, gamma and trend follow the estimate.
  TemperatureBand temperature;
  /// Longest gap of the thermometer's samples bridged by interpolation, and how far its first
  /// and last sample hold at the window's edges, s (a hut's heater cycles in half an hour: not
  /// the magnetic records' max_fill_s).
  double temperature_max_gap_s = 60.0;
  /// The main field's direction at the station (the observatory's D and I), for the scalar
  /// check's per-axis scales; none: not known.
  std::optional<FieldDirection> field_direction;
  /// The yardstick of the verdicts (default: INTERMAGNET's 1-second standard).
  Tolerances tolerances;
  /// max_fill_s: the longest gap filled without flagging the window, s (one hour, gap_filling.hpp);
  /// what limits shorter gaps is the share of the window they fill (max_filled_fraction).
  GapSettings gaps;
  double max_filled_fraction = 0.05;  ///< of the window's expected epochs, [0, 1]

  /// The errors-in-variables correction may use a noise model: robust method, correction on.
  bool corrects_reference_noise() const {
    return estimator.method == EstimatorMethod::kRobust && estimator.robust.errors_in_variables;
  }
  /// Throws InputError naming the field when a value is impossible.
  void validate() const;
};

/// Readings of the test sensor's thermometer around a window (UNIX s, deg C; NaN = missing).
struct TemperatureSamples {
  bool recorded = false;        ///< the test instrument has a temperature at all
  std::vector<double> time_s;   ///< strictly increasing
  std::vector<double> value_C;
};

/// One window of the pair and the measured inputs that go with it.
struct WindowRecords {
  double start_s = 0.0;              ///< nominal first epoch, UNIX s
  double period_s = 1.0;             ///< sample period of the estimation grid, s
  std::size_t expected_samples = 0;  ///< epochs of the window
  /// Reference frame / test frame, nT, on the estimation grid (or within a quarter period of it);
  /// a missing epoch is NaN or absent.
  PairedRecord paired;
  TemperatureSamples temperature;    ///< the test sensor's thermometer around the window
  /// A third instrument's samples on the same estimation epochs (its own frame, nT; NaN or
  /// absent = missing: a side record's, side_stream.hpp, or another test's complete epochs), for
  /// the three-cornered hat; null: none.
  std::shared_ptr<const VectorRecord> third;
  std::string third_name;            ///< names the third in texts and errors ("--third", "test 'b'")
  /// A remote observatory's samples around the window (its own frame and units, nT, on the same
  /// estimation grid; NaN = missing), the instruments of a remote-reference estimate
  /// (estimation/remote_reference.hpp); null: none.
  std::shared_ptr<const VectorRecord> remote;
  std::string remote_name;           ///< names the remote in texts ("--remote", a station, a topic)
  /// Live: why the remote's samples stop before the window's end (it went on without waiting
  /// longer for them, LiveStreamSettings::remote_max_wait_s); "" when they reach it.
  std::string remote_late;
  /// An absolute scalar magnetometer's samples around the window (F, nT, its own times): the
  /// check of the reference's scale along the field (pipeline/scalar_window.hpp); null: none.
  std::shared_ptr<const ScalarRecord> scalar;
  /// The low-pass and decimation the pair went through onto the grid, if it did (the scalar
  /// check puts F through the same).
  std::optional<DecimationSettings> decimation;

  /// Nominal last epoch, UNIX s.
  double end_s() const { return start_s + (static_cast<double>(expected_samples) - 1.0) * period_s; }
};

/// The whole result of one window.
struct CalibrationWindow {
  std::string label;            ///< "interval 2/4", "whole record", "window 7"; empty for a live window
  std::size_t first_index = 0;  ///< offline: the window's first epoch on the record's grid
  double start_s = 0.0, end_s = 0.0;  ///< nominal first and last epoch, UNIX s
  std::size_t expected_samples = 0;
  std::size_t leading_missing = 0;    ///< epochs before the first complete one
  std::size_t trailing_missing = 0;   ///< epochs after the last complete one
  std::size_t interpolated = 0;       ///< epochs filled inside
  bool long_gap = false;              ///< a gap (inside, or at an edge) longer than max_fill_s
  WindowEstimate estimate;            ///< quality kGaps when the gap rule fails
  /// The identification of the reference's noise for this window (hat or pair), or why there
  /// was none; estimate.eiv and estimate.eiv_noise say what the correction used.
  IdentifiedNoise reference_noise;
  /// Gain and phase of T against R n per test component, lowest band first, and their summary
  /// over the band used; empty when not asked for or when no band has enough harmonics.
  std::vector<ResponseBand> relative_response;
  ResponseSummary response;
  /// The response model: fitted and applied, or why not (text).
  ResponseModel response_model;
  /// The reference against the scalar magnetometer (when the window has one): its scale along
  /// the main field, the field's direction, the test's scale through n.
  ScalarCheck scalar;
  /// Why the window's remote was not used before any estimate (its samples do not cover the
  /// window); "" otherwise (estimate.remote says the rest).
  std::string remote_refused;
  /// Each parameter against its tolerance (step 6), and how the window's intervals narrow with
  /// record length (measured only when a verdict is undecided; its text says why not otherwise).
  std::vector<ToleranceVerdict> verdicts;
  IntervalNarrowing narrowing;
  /// Temperature terms: fitted, or why not (text). When fitted, the estimate, the relative
  /// response and the offset are those of T with the terms removed, n at temperature.reference_C.
  TemperatureFit temperature;
  std::size_t temperature_samples = 0;  ///< thermometer samples given with the window
  bool temperature_known = false;       ///< a finite temperature at every epoch of the grid
  /// Baseline of the test relative to the reference (test frame, nT), model
  /// T = R n + d + trend (t - t_c) + e with t_c the mean epoch of the window's samples:
  ///   d = mean(T) - mean(R) n,   d_end = d + trend (end_s - t_c)   (trend in nT/s).
  /// 95 % half-width of d_end per component l (the normal quantile: N samples):
  ///   1.96 sqrt( m^T C_l m + s_l^2 / N + (end_s - t_c)^2 se_trend_l^2 ),
  /// m = mean(R), C_l = Cov of column l of n, s_l the rms of the time-domain residual e_l.
  Eigen::Vector3d offset_centre_nT = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d offset_end_nT = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d offset_end_ci95_nT = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// m = mean(R) over the window (reference frame, nT): the offset absorbs the error of n at m,
  /// so a corrected reading's error from dn is (r - m)^T dn n^-1.
  Eigen::Vector3d reference_mean_nT = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());

  /// Epochs without data: interpolated inside or missing at the edges.
  std::size_t missing() const { return leading_missing + trailing_missing + interpolated; }
};

/// The thermometer on the grid `at` (UNIX s): interpolate_channel (linear, NaN across gaps
/// longer than max_gap_s); epochs before the first or after the last sample take that sample's
/// value when it is at most max_gap_s away, NaN otherwise.
Eigen::VectorXd temperature_on_grid(const TemperatureSamples& samples, const std::vector<double>& at, double max_gap_s);

/// The per-window stage; keeps the estimator's FFTW plans and buffers between windows. One per
/// thread.
class WindowCalibrator {
 public:
  /// Throws InputError naming the first impossible setting.
  explicit WindowCalibrator(const WindowCalibrationSettings& settings);
  ~WindowCalibrator();
  WindowCalibrator(const WindowCalibrator&) = delete;
  WindowCalibrator& operator=(const WindowCalibrator&) = delete;

  /// Steps 1-5 above. Throws InputError when the window cannot be put on its grid (no complete
  /// epoch, stamps off the grid).
  CalibrationWindow calibrate(WindowRecords window);

  const WindowCalibrationSettings& settings() const { return settings_; }

 private:
  struct Pass;
  CalibrationParameters estimate_pass(CalibrationWindow& w, const PairedRecord& paired,
                                      const Eigen::VectorXd& temperature_C, double period_s, const WindowInputs& inputs);
  void decide_tolerances(CalibrationWindow& w, const PairedRecord& filled, double period_s, const WindowInputs& inputs,
                         const CalibrationParameters& estimator_parameters);
  ReferenceNoiseModel noise_before_estimate(CalibrationWindow& w, const WindowRecords& window,
                                            const PairedRecord& filled);

  WindowCalibrationSettings settings_;
  WindowEstimator estimator_;
  WindowEstimator scalar_estimator_;  ///< F's fit (its own window length: its own plans)
};

}  // namespace magnetometer_insitu_calibration
