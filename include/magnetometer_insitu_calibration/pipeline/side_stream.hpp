// A stream measured beside the pair, a remote observatory (remote reference) or a third
// co-located instrument (three-cornered hat), brought onto the estimation epochs on its own:
// one class for calibrate_records (prepare_sides feeds it a whole record) and calibration_node
// (LiveCalibrationStreams feeds it samples as they arrive), so that a window gets the same side
// samples either way.
//
// The side stream is never paired with the reference as a test is. Its way, in the order the
// pair's own pre-processing takes (calibration_pipeline.hpp):
//   sample -> StreamingDespiker (at its own rate; optional, as for every stream)
//          -> onto the estimation epochs by the rule the pair follows (plan_epochs against the
//             reference's period and phase): through its own StreamingDecimator (the pair's
//             Gaussian FIR, kernels centred on the epochs j * period) when the rule filters,
//             else at its own stamps;
//          -> its samples on the epochs, kept while the windows still to complete need them.
// The reference's gaps are the side's too: an epoch where the reference (through the same
// filter, when the rule filters) has no finite value, or no sample within the pairing tolerance
// of the side's (at its stamps), gives the side no value there (NaN). For that the reference's
// stream comes in as well, and only whether it has a finite value at each epoch is kept.
// Units: nT and UNIX seconds; the side in its own frame.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"
#include "magnetometer_insitu_calibration/pipeline/epoch_alignment.hpp"
#include "magnetometer_insitu_calibration/preprocessing/despike.hpp"
#include "magnetometer_insitu_calibration/preprocessing/gaussian_decimation.hpp"
#include "magnetometer_insitu_calibration/preprocessing/streaming_despike.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <deque>
#include <limits>
#include <memory>
#include <optional>
#include <utility>

namespace magnetometer_insitu_calibration {

/// How a side stream comes onto the estimation epochs.
struct SideStreamSettings {
  double reference_period_s = 1.0;  ///< the reference's nominal sample period, s
  double side_period_s = 1.0;       ///< the side stream's nominal sample period, s
  /// Its stamps fall at another phase of one period than the reference's (further off than
  /// pairing_tolerance_s): the rule then filters it onto the epochs, as it does two rates.
  bool stamps_apart = false;
  DecimationSettings decimation;    ///< output_period_s: the estimation period asked for, s
  /// At its stamps: how far its sample may lie from the reference's of the same epoch, s.
  double pairing_tolerance_s = 0.010;
  bool despike = true;              ///< StreamingDespiker on the side stream
  DespikeSettings despike_settings;
  /// A step of a filtered stream's stamps longer than this (and than the kernel's support and an
  /// epoch) restarts its filter, s; its epochs inside the step are missing either way.
  /// Infinite: never (a record, as decimate() takes it).
  double time_jump_threshold_s = 60.0;

  /// The pair's rule (plan_epochs) for the reference and this stream.
  EpochPlan plan() const;
  /// How the side stream comes onto the epochs under that rule: kEachFiltered whenever the rule
  /// filters (either of the pair's ways puts a stream that has no partner through the same
  /// kernel onto the same epochs j * period), else kPairedStamps (at its own stamps).
  EpochAlignment alignment() const;
};

class SideStream {
 public:
  /// Throws InputError naming the field for impossible settings (a period, the despiker's
  /// settings, a filter kernel shorter than a stream's period).
  explicit SideStream(const SideStreamSettings& settings);

  /// kEachFiltered: through the Gaussian FIR onto the epochs j * period_s(); kPairedStamps: at
  /// its own stamps, on the reference's epochs.
  EpochAlignment alignment() const { return alignment_; }
  /// The estimation period its epochs come at, s (the pair's must be the same).
  double period_s() const { return period_s_; }
  /// The filter it goes through; none at its stamps.
  const std::optional<DecimationSettings>& filter() const { return filter_; }

  /// The reference's sample as the pair takes it (despiked, reference frame, nT).
  void push_reference(double time_s, const Eigen::Vector3d& value_nT);
  /// The side stream's own sample (its frame, nT; NaN = missing). A sample not after the
  /// previous one (once despiked) is ignored and counted in rejected().
  void push(double time_s, const Eigen::Vector3d& value_nT);
  /// The end of a record: the despiker decides its last samples (the epochs after them need
  /// samples that never come).
  void finish();

  /// Its samples on the epochs within [low_s, high_s), in time order: each at the reference's
  /// epoch it lies on; NaN in all three components where the side or the reference has a NaN in
  /// any (a gap, a spike taken out), as the pair's grid masks an incomplete epoch.
  VectorRecord on_epochs(double low_s, double high_s) const;
  /// The latest epoch both the side and the reference have reached, UNIX s (-inf before any),
  /// also once drop_before() has forgotten their epochs: a window ending there has every side
  /// sample it will get.
  double reached_s() const;
  /// The newest epoch either has reached, UNIX s (-inf before any).
  double newest_s() const;
  /// Forgets the epochs before time_s (no window still to complete needs them).
  void drop_before(double time_s);
  /// Forgets everything but the counters (the reference's stamps went back).
  void reset();

  std::size_t received() const { return received_; }        ///< side samples pushed
  std::size_t spikes() const { return despiker_.spikes(); }  ///< side values the despiker set NaN
  std::size_t rejected() const;                               ///< side samples not after the previous one
  std::size_t restarts() const;                               ///< filter restarts after a jump of the stamps
  std::size_t buffered() const { return side_.size() + reference_.size(); }  ///< epochs held

 private:
  struct Epoch {
    double time_s;
    Eigen::Vector3d value_nT;
  };
  /// A despiked side sample onto the epochs: as it is, or through the side's filter.
  void filter_side(double time_s, const Eigen::Vector3d& value_nT);
  void add_side(double time_s, const Eigen::Vector3d& value_nT);
  void add_reference(double time_s, bool finite);

  SideStreamSettings settings_;
  EpochAlignment alignment_;
  double period_s_;
  std::optional<DecimationSettings> filter_;
  StreamingDespiker despiker_;
  std::unique_ptr<StreamingDecimator> reference_filter_, side_filter_;  ///< when filtered
  std::deque<Epoch> side_;                          ///< its samples on the epochs, time order
  std::deque<std::pair<double, bool>> reference_;   ///< the reference's epochs: time, finite
  /// The newest epoch each has reached (-inf before any), kept when drop_before() has forgotten
  /// every epoch: a remote that stopped before the windows still waiting has still reached it.
  double side_reached_s_ = -std::numeric_limits<double>::infinity();
  double reference_reached_s_ = -std::numeric_limits<double>::infinity();
  std::size_t received_ = 0;
  std::size_t rejected_at_stamps_ = 0;  ///< rejected before the filter would see them (at its stamps)
};

}  // namespace magnetometer_insitu_calibration
