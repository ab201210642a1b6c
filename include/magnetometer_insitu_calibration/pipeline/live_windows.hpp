// The live side of calibration: the buffers that turn arriving samples into the windows the
// per-window stage (window_calibration.hpp) calibrates. ROS-free; calibration_node adapts its
// messages to them (live_streams.hpp puts them together per test instrument).
#pragma once

#include "magnetometer_insitu_calibration/pipeline/window_calibration.hpp"
#include "magnetometer_insitu_calibration/preprocessing/stream_pairing.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <deque>
#include <map>
#include <optional>
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
/// It also measures the stream's sample period on its stamps, so that a stream at another rate
/// than its parameter says (a LEMI-025 at 10 Hz under the default ~input_period of 1 s) is told
/// within seconds, not when its first window fails a day later.
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

  /// Steps kept for the period: the stream's last kPeriodSteps steps forward between
  /// consecutive stamps, shorter than the jump threshold.
  static constexpr std::size_t kPeriodSteps = 101;
  /// Fewer steps than this: no period measured yet.
  static constexpr std::size_t kMinPeriodSteps = 20;
  /// The stream's sample period measured on its stamps: the median of the steps kept, s; NaN
  /// before kMinPeriodSteps of them.
  double measured_period_s() const;
  /// "" when the measured period is within 10 % of nominal_period_s (or not measured yet), else
  /// what differs: "stamps step by 0.1 s, not 1 s".
  std::string period_problem(double nominal_period_s) const;
  /// Where in each period of period_s its last kPeriodSteps stamps (stray ones left out) fall:
  /// their circular mean phase, s in [-period/2, period/2) (stamp_phase_s of time_steps.hpp);
  /// NaN before kMinPeriodSteps stamps, or when they share no phase.
  double stamp_phase_s(double period_s) const;

 private:
  void keep_stamp(double stamp_s);

  bool behind_ = false;  ///< the previous sample was far behind the newest stamp
  double previous_stamp_s_ = 0.0;  ///< the stamp of the previous message, UNIX s
  std::deque<double> steps_;       ///< the last steps forward, s
  std::deque<double> stamps_;      ///< the last stamps, stray ones left out, UNIX s
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
  /// Samples with low_s <= t <= high_s (recorded = true).
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
  std::vector<WindowRecords> push(double time_s, const Eigen::Vector3d& reference_nT, const Eigen::Vector3d& test_nT);

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
  WindowRecords copy_window(double start_s) const;

  double window_s_, step_s_, period_s_;
  std::size_t expected_samples_;
  std::deque<PairedSample> buffer_;
  bool started_ = false;
  double next_start_ = 0.0;  ///< start of the next window to complete
  double last_time_s_ = 0.0;
  std::size_t emitted_ = 0, skipped_empty_ = 0, out_of_order_ = 0;
};

/// The windows of `channels` test instruments, grouped by start (UNIX s). A channel's completed
/// window waits until every channel has completed the window of that start, or any channel has
/// completed a later one; the group is then released, oldest start first. So a window waits at
/// most one ~step for its mates: when an instrument is silent, or its window had no sample, the
/// others go without it (their window has no third and is estimated without the hat).
class CoincidentWindows {
 public:
  explicit CoincidentWindows(std::size_t channels);

  struct Released {
    std::size_t channel = 0;
    WindowRecords window;
    /// The channel whose test samples are window.third (its window of the same start, at the
    /// epochs where its pair is complete: the next channel in order that has one); meaningful
    /// when window.third is set.
    std::size_t mate_channel = 0;
  };

  /// Adds the window `channel` completed; returns the windows released by it (every channel's
  /// window of a released start, in channel order, oldest start first).
  std::vector<Released> add(std::size_t channel, WindowRecords&& window);
  /// Windows waiting for their mates.
  std::size_t pending() const;
  /// Forgets a channel's waiting windows and its newest start (after its stamps went back);
  /// the other channels' waiting windows are released by their next window.
  void reset(std::size_t channel);

 private:
  std::size_t channels_;
  std::map<double, std::vector<std::optional<WindowRecords>>> pending_;  ///< by start, one slot per channel
  std::vector<double> newest_start_;                                 ///< per channel, -inf before any
};

}  // namespace magnetometer_insitu_calibration
