// ROS-free helpers of calibration_node: the sliding window over the live paired stream, and the
// preparation + estimate of one window (regularize_and_fill on the window copy, gap flags).
#pragma once

#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/preprocessing/despike.hpp"
#include "magnetometer_insitu_calibration/preprocessing/gap_filling.hpp"
#include "magnetometer_insitu_calibration/estimation/relative_response.hpp"
#include "magnetometer_insitu_calibration/estimation/response_model.hpp"
#include "magnetometer_insitu_calibration/estimation/robust_estimator.hpp"
#include "magnetometer_insitu_calibration/estimation/temperature_terms.hpp"
#include "magnetometer_insitu_calibration/preprocessing/stream_pairing.hpp"
#include "magnetometer_insitu_calibration/preprocessing/time_alignment.hpp"

#include <cstddef>
#include <deque>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace magnetometer_insitu_calibration {

/// Arrival and stamp bookkeeping of one input topic (diagnostics and time jumps).
/// Jumps are judged against the newest stamp of the stream:
///  * forward: a stamp more than threshold_s after the newest one (a clock jump, or a gap in
///    the data); counted, the stream goes on from there;
///  * backward: a stamp more than threshold_s before the newest one. A single such sample (a
///    stray stamp, e.g. 0) is only counted in `stray`; it takes two in a row to confirm a
///    backward jump (a clock set back), which is counted and returned as kBackward once, so
///    that the caller restarts the pipeline (the pairer would otherwise drop every later sample
///    as late).
struct StreamMonitor {
  enum class Jump { kNone, kForward, kBackward };
  std::string topic;
  std::string frame_id;                   ///< of the newest message
  std::size_t messages = 0;
  std::size_t jumps_forward = 0;
  std::size_t jumps_backward = 0;         ///< confirmed backward jumps
  std::size_t stray = 0;                  ///< single samples far behind the newest stamp
  double newest_stamp_s = 0.0;            ///< UNIX s
  double last_arrival_s = 0.0;            ///< ROS time, s

  Jump observe(double stamp_s, double arrival_s, const std::string& frame, double threshold_s);
  /// ROS-time seconds since the last message (or since `since_s` when none yet).
  double silence_s(double now_s, double since_s) const;

 private:
  bool behind_ = false;  ///< the previous sample was far behind the newest stamp
};

/// Readings of the test sensor's thermometer (UNIX s, deg C; NaN = missing) for one window.
struct TemperatureSamples {
  bool subscribed = false;            ///< the instrument has a temperature topic
  std::vector<double> time_s;         ///< strictly increasing
  std::vector<double> value_C;
};

/// The thermometer's samples of one test instrument, kept for the windows still to complete:
/// push() appends (a stamp not later than the previous one is ignored and counted), copy()
/// takes the samples of a window with a margin on both sides, drop_before() forgets what no
/// later window needs. Bounded: samples older than the newest by more than span_s are dropped
/// too (a temperature topic without field data does not grow the buffer).
class TemperatureBuffer {
 public:
  explicit TemperatureBuffer(double span_s) : span_s_(span_s) {}
  void push(double time_s, double value_C);
  /// Samples with low_s <= t <= high_s, subscribed = true.
  TemperatureSamples copy(double low_s, double high_s) const;
  void drop_before(double time_s);
  void reset() { samples_.clear(); }
  std::size_t buffered() const { return samples_.size(); }
  std::size_t out_of_order() const { return out_of_order_; }

 private:
  double span_s_;
  std::deque<std::pair<double, double>> samples_;
  std::size_t out_of_order_ = 0;
};

/// The thermometer on the window's grid `at` (UNIX s): interpolate_channel (linear, NaN across
/// gaps longer than max_gap_s); epochs before the first or after the last sample take that
/// sample's value when it is at most max_gap_s away (the thermometer's topic may lag the
/// field's by a sample when the window completes), NaN otherwise.
Eigen::VectorXd temperature_on_grid(const TemperatureSamples& samples, const std::vector<double>& at, double max_gap_s);

/// One window of the live stream, copied out of the buffer for the estimator.
struct WindowData {
  double start_s = 0.0;               ///< nominal first epoch, UNIX s (a whole multiple of step)
  double period_s = 1.0;              ///< sample period of the estimation grid, s
  std::size_t expected_samples = 0;   ///< round(window / period)
  PairedRecord paired;                ///< samples in the window, reference frame / test frame, nT (NaN = missing)
  TemperatureSamples temperature;     ///< the test sensor's thermometer around the window (attached by the node)

  /// Nominal last epoch, UNIX s.
  double end_s() const { return start_s + (static_cast<double>(expected_samples) - 1.0) * period_s; }
};

/// Sliding windows [start, start + window) over a time-ordered stream of paired samples on the
/// estimation grid (after decimation). Window starts are whole multiples of step_s in UNIX time,
/// so that nodes on several machines use the same windows. A window is complete (returned by
/// push) when the first sample at or after its end arrives. Boundaries are shifted by half a
/// period (a sample at start - period / 2 <= t < end - period / 2 belongs to the window), so stamps
/// with rounding noise fall into the right window. Windows without any sample (inside a long
/// silence or a forward time jump) are skipped and counted.
class SlidingWindowBuffer {
 public:
  /// window_s, step_s, period_s > 0 and step_s <= window_s (checked by the node's settings).
  SlidingWindowBuffer(double window_s, double step_s, double period_s);

  /// Adds one sample (reference stamp, reference frame nT, test frame nT; NaN allowed).
  /// A sample not later than the previous one is ignored and counted in out_of_order().
  /// Returns the windows completed by it, oldest first.
  std::vector<WindowData> push(double time_s, const Eigen::Vector3d& reference_nT, const Eigen::Vector3d& test_nT);

  /// Forgets everything but the counters (after a backward time jump).
  void reset();

  std::size_t buffered() const { return buffer_.size(); }
  std::size_t windows_emitted() const { return emitted_; }
  std::size_t windows_skipped_empty() const { return skipped_empty_; }
  std::size_t out_of_order() const { return out_of_order_; }
  /// Start of the next window to complete, UNIX s (samples before it minus half a period are no
  /// longer needed).
  double next_start_s() const { return next_start_; }
  double window_s() const { return window_s_; }
  double step_s() const { return step_s_; }
  double period_s() const { return period_s_; }

 private:
  WindowData copy_window(double start_s) const;

  double window_s_, step_s_, period_s_;
  std::size_t expected_samples_;
  std::deque<PairedSample> buffer_;
  bool started_ = false;
  double next_start_ = 0.0;  ///< start of the next window to complete
  double last_time_s_ = 0.0;
  std::size_t emitted_ = 0, skipped_empty_ = 0, out_of_order_ = 0;
};

/// Gap rule of a window (as calibrate_prepared applies it offline, extended to the edges).
struct WindowGapRule {
  /// Spikes removed from both records of the window before the gaps are filled (despike.hpp,
  /// its default settings on the estimation grid, not within 2 half-windows of the window's
  /// ends; ~despike). Off by default: offline despikes the records at their own rate before
  /// decimation, so a despiked window would no longer be the offline window (replay_agreement);
  /// spikes are left to the robust screen, whose fill by local means keeps them from moving n.
  bool despike = false;
  DespikeSettings despike_settings;
  GapSettings gaps;                   ///< max_fill_s: longest gap filled without flagging, s
  double max_filled_fraction = 0.05;  ///< of the window's expected samples, [0, 1]
  /// Temperature terms (only min_range_C is used; band, gamma and trend are the estimator's).
  TemperatureBand temperature;
  /// Longest gap of the thermometer's samples bridged by interpolation (temperature_on_grid), s.
  double temperature_max_gap_s = 60.0;
  /// Response model (response_model.hpp) of every window estimated by the WindowEstimator: where a
  /// test component's 1-pole corner is significant, n is estimated through it (~response_model).
  bool response_model = true;
  ResponseModelSettings model;
};

struct WindowResult {
  double start_s = 0.0, end_s = 0.0;  ///< nominal first and last epoch, UNIX s
  std::size_t expected_samples = 0;
  std::size_t leading_missing = 0;    ///< epochs of the window before the first complete one
  std::size_t trailing_missing = 0;   ///< epochs after the last complete one
  std::size_t interpolated = 0;       ///< epochs filled inside (regularize_and_fill)
  std::size_t spikes = 0;             ///< values set to NaN by despike (both records), then filled
  bool long_gap = false;              ///< a gap (inside or at an edge) longer than max_fill_s
  WindowEstimate estimate;            ///< quality kGaps when the gap rule fails
  /// Relative response of the test against R n (relative_response.hpp) and its summary over the
  /// band used: largest |gain - 1| with its half-width, group delay (s), for the diagnostics.
  std::vector<ResponseBand> relative_response;
  ResponseSummary response;
  /// The response model of the window: fitted and applied, or why not (text); not fitted when
  /// rule.response_model is off or the estimator is the plain FdWlseEstimator.
  ResponseModel response_model;
  /// Baseline of the test relative to the reference (test frame, nT), model
  /// T = R n + d + trend (t - t_c) + e with t_c the mean epoch of the window's samples (the trend
  /// column is centred there, so d is the offset at the window centre):
  ///   d = mean(T) - mean(R) n,   d_end = d + trend (end_s - t_c)   (trend in nT/s).
  /// 95 % half-width of d_end per component l:
  ///   1.96 sqrt( m^T C_l m + s_l^2 / N + (end_s - t_c)^2 se_trend_l^2 ),
  /// m = mean(R) (reference frame, nT), C_l = Cov of column l of n (from n_covariance), s_l the
  /// rms of the time-domain residual e_l, N the samples. The s_l^2 / N term treats the residual
  /// as white (it is small next to m^T C_l m for a main field of tens of thousands of nT).
  Eigen::Vector3d offset_centre_nT = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d offset_end_nT = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d offset_end_ci95_nT = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// m = mean(R) over the window's samples (reference frame, nT): where the offset absorbs the
  /// error of n (d = mean(T) - m n), so a corrected reading's error from dn is (r - m)^T dn n^-1.
  Eigen::Vector3d reference_mean_nT = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// Temperature terms (temperature_terms.hpp): fitted, or why not (text). When fitted, the
  /// estimate, the relative response and the offset are those of T with the terms removed, n at
  /// temperature.reference_C.
  TemperatureFit temperature;
  std::size_t temperature_samples = 0;  ///< thermometer samples attached to the window
  bool temperature_known = false;       ///< a finite temperature at every epoch of the grid
  /// Epochs without data: interpolated inside or missing at the edges.
  std::size_t missing() const { return leading_missing + trailing_missing + interpolated; }
};

/// Despikes one record of a window (despike.hpp) as the offline pipeline despikes the whole
/// record: a flag within 2 half-windows of either end of the window, where the running medians
/// lack the context the whole record gives them, is not applied (the value is kept). Inside,
/// the flags are those of the whole record. Returns the values set to NaN.
std::size_t despike_window(Readings& values, const DespikeSettings& settings);

/// Puts the window copy on its regular grid and fills gaps (regularize_and_fill: the same rule
/// as offline, on both instruments at the same epochs), estimates n with `estimator`, and flags
/// the window Quality::kGaps when more than max_filled_fraction of its expected epochs are
/// interpolated or missing at its edges, or when a gap longer than max_fill_s lies inside or at
/// an edge. Unlike the offline rule this takes precedence over the estimator's own flags (a
/// window shortened by missing data also fails min_harmonics, but the cause is the gap; the
/// estimator's text is appended). Throws InputError when the window cannot be put on a grid
/// (e.g. no complete epoch; stamps off the grid). With window.temperature.subscribed, the
/// thermometer goes onto the grid (temperature_on_grid, rule.temperature_max_gap_s) and the
/// temperature terms are fitted and removed as offline (with_temperature_terms); without it, or
/// with a missing or too constant temperature, the window is estimated without them and
/// result.temperature.text says why.
/// The FdWlseEstimator form never fits temperature terms (text says so).
WindowResult estimate_window(WindowData window, FdWlseEstimator& estimator, const WindowGapRule& rule);
/// The same with the estimator the offline CLI uses (plain or robust, auto band, delay, EIV).
WindowResult estimate_window(WindowData window, WindowEstimator& estimator, const WindowGapRule& rule);

}  // namespace magnetometer_insitu_calibration
