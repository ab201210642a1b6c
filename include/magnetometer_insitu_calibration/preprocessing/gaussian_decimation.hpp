// Gaussian FIR low-pass filter and decimation (10 Hz -> 1 Hz by default), batch and streaming.
#pragma once

#include "magnetometer_insitu_calibration/common/scalar_record.hpp"
#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <deque>
#include <utility>
#include <vector>

namespace magnetometer_insitu_calibration {

/// Default kernel width: sigma = sqrt(ln(100) / 2) / (pi * f_N) with f_N = 1 / (2 T_out), so
/// that the gain exp(-2 pi^2 sigma^2 f^2) is 0.01 at the output Nyquist frequency f_N.
/// For T_out = 1 s: sigma = 0.966 s, gain 0.99816 at 0.01 Hz, 0.955 at 0.05 Hz, 0.01 at 0.5 Hz.
struct DecimationSettings {
  double output_period_s = 1.0;   ///< T_out, s; outputs at whole multiples of it (UNIX time)
  double sigma_s = 0;             ///< kernel standard deviation, s; 0 = default (see above)
  double half_width_sigmas = 4.0; ///< kernel support |t - t_out| <= half_width_sigmas * sigma

  /// Throws InputError naming the field when a value is impossible.
  void validate() const;
  /// sigma_s, or the default when sigma_s == 0, s.
  double effective_sigma_s() const;
  /// Half-width h of the kernel support, s.
  double half_width_s() const { return half_width_sigmas * effective_sigma_s(); }
};

/// Amplitude response of the continuous Gaussian kernel: exp(-2 pi^2 sigma^2 f^2).
double gaussian_gain(double sigma_s, double frequency_hz);

/// The filter, as implemented by decimate() and StreamingDecimator (which agree exactly):
///  * Output epochs t_o = j * T_out (j integer) whose support [t_o - h, t_o + h] lies strictly
///    inside the input's time span (first input < t_o - h, t_o + h < last input).
///  * Output = sum_k w_k x_k / sum_k w_k over the input samples k with |t_k - t_o| <= h,
///    w_k = exp(-(t_k - t_o)^2 / (2 sigma^2)): the kernel is centred on t_o itself, whatever
///    the phase of the input grid (e.g. the LEMI-025 -0.3 s shift) and normalised to unit sum.
///  * NaN when any of those samples has a NaN in any component, or when a gap overlaps the
///    support: a gap is the time between two consecutive input samples more than 1.5 input
///    periods apart (it holds at least one missing sample).
///
/// Batch version. The input must be in time order and (nearly) regular; its period is the
/// median step. Returns a record with the same metadata (components, source, station, header).
/// Throws InputError(input.source, ...) for fewer than two samples or stamps not increasing
/// (naming the sample), and InputError for impossible settings.
VectorRecord decimate(const VectorRecord& input, const DecimationSettings& settings);

/// A scalar magnetometer's F through decimate()'s filter onto its output epochs j * T_out: what F
/// goes through before it is compared with a pair that decimate() has low-passed. Else the pair's
/// gain (0.955 at 0.05 Hz for 1 s output) is read as the reference's scale; and the kernel, centred
/// on each epoch, takes F's samples off the epochs (0.37 s for a GP20S3) without the loss a linear
/// interpolation onto them has (1.1 % at 0.05 Hz). F sparser than the output epochs (its median
/// step over 1.5 T_out: every 30 s) comes back unchanged: the check then puts the reference on
/// F's own times.
ScalarRecord decimate_scalar(const ScalarRecord& input, const DecimationSettings& settings);

/// The same filter for a live stream: push samples in time order, collect the outputs; they
/// equal decimate() of the same samples (to rounding) as long as no step between consecutive
/// samples exceeds restart_gap_s.
/// An output t_o is completed (returned by push) by the first sample later than t_o + h, so the
/// latency is h plus one input period (4.96 s with the defaults at 10 Hz). After a gap push
/// returns all the (NaN) outputs inside it at once. A sample that is not later than the
/// previous one, or has a non-finite stamp, is ignored and counted in rejected(). A step of
/// more than restart_gap_s, forwards or backwards (a clock jump, or a restart of the
/// instrument), instead starts a new record at that sample, as reset() would, counted in
/// restarts(): a bad stamp far in the future can then neither flood the caller with NaN
/// outputs nor block every later sample.
class StreamingDecimator {
 public:
  explicit StreamingDecimator(double input_period_s, const DecimationSettings& settings = {},
                              double restart_gap_s = 3600.0);

  /// Pushes one input sample (UNIX seconds, nT); returns the outputs completed by it, in order.
  std::vector<std::pair<double, Eigen::Vector3d>> push(double time_s, const Eigen::Vector3d& value_nT);

  /// Forgets all samples: the next push starts a new record (outputs restart after h).
  void reset();

  double input_period_s() const { return input_period_s_; }
  double sigma_s() const { return sigma_s_; }
  double half_width_s() const { return half_width_s_; }
  double restart_gap_s() const { return restart_gap_s_; }
  std::size_t rejected() const { return rejected_; }
  std::size_t restarts() const { return restarts_; }
  std::size_t buffered() const { return time_s_.size(); }

 private:
  double input_period_s_;
  double output_period_s_;
  double sigma_s_;
  double half_width_s_;
  double restart_gap_s_;
  std::deque<double> time_s_;
  std::deque<Eigen::Vector3d> value_nT_;
  long long next_output_ = 0;  ///< j of the next output epoch j * T_out
  std::size_t rejected_ = 0;
  std::size_t restarts_ = 0;
};

}  // namespace magnetometer_insitu_calibration
