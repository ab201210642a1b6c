// Spike removal of a live stream: despike() (despike.hpp) applied sample by sample, so that a
// stream despiked as it arrives holds exactly the values of the whole record despiked at once.
#pragma once

#include "magnetometer_insitu_calibration/preprocessing/despike.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace magnetometer_insitu_calibration {

/// despike()'s rule on a stream of three-component samples. A sample is decided once the 2w
/// samples after it have arrived (w = half_window: its median window and the median windows
/// of its neighbours, whose residuals make its MAD and whose medians its curvature term, reach
/// that far), so the stream comes out 2w samples late (3 s at 10 Hz with the default w = 15,
/// 30 s at 1 Hz). Windows are clipped at the stream's start as despike() clips them at the
/// record's start; flush() decides the last 2w samples with the windows clipped at the end. A
/// stream pushed whole and flushed gives exactly despike() of the same samples (same flags,
/// same doubles). Index-based like despike(): a gap in time is just the next sample.
class StreamingDespiker {
 public:
  struct Sample {
    double time_s = 0.0;
    Eigen::Vector3d value_nT = Eigen::Vector3d::Zero();  ///< a spike's component is NaN
  };

  /// Throws InputError naming the field for impossible settings.
  explicit StreamingDespiker(const DespikeSettings& settings = {});

  /// Adds one sample (NaN components pass through, never counted); returns the sample decided
  /// by it (at most one: the one 2w samples back), in `out`, and whether there is one.
  bool push(double time_s, const Eigen::Vector3d& value_nT, Sample& out);
  /// Decides every sample still held, as despike() decides a record's last 2w samples.
  std::vector<Sample> flush();
  /// Forgets the stream (a restart after stamps went back): the next sample starts a new one.
  void reset();

  std::size_t spikes() const { return spikes_; }          ///< values set to NaN since construction
  std::size_t held() const { return received_ - decided_; }  ///< samples waiting for their decision
  std::size_t delay_samples() const { return 2 * w_; }

 private:
  void compute_median(std::size_t j, std::size_t last);
  Sample decide(std::size_t i, std::size_t last);
  std::size_t slot(std::size_t k) const { return k % capacity_; }

  DespikeSettings settings_;
  std::size_t w_;
  std::size_t capacity_;  ///< ring length: the 4w + 1 samples a decision looks at, plus one
  std::vector<double> time_s_;
  std::vector<Eigen::Vector3d> x_, median_, residual_;
  std::vector<Eigen::Matrix<std::size_t, 3, 1>> count_;
  std::vector<double> scratch_;
  std::size_t received_ = 0;  ///< samples pushed since the last reset (absolute index of the next)
  std::size_t medians_ = 0;   ///< samples whose median is computed
  std::size_t decided_ = 0;   ///< samples decided
  std::size_t spikes_ = 0;
};

}  // namespace magnetometer_insitu_calibration
