// ROS-free part of calibration_node's three-cornered hat (issue 13, ~three_cornered_hat): with two
// or more test instruments against one reference on one node, the reference's noise is
// identified in every window from the reference and two tests (pipeline/reference_noise.hpp)
// and given to the errors-in-variables correction, as a maker's noise figure would be.
//
//  - CoincidentWindows groups the windows the test instruments complete for the same start
//    (same reference epochs: every channel's windows start at whole multiples of ~step), so
//    that each window goes to the worker with another instrument's record of the same epochs.
//  - estimate_window_with_hat() is the worker's estimate of one window with that record.
#pragma once

#include "magnetometer_insitu_calibration/pipeline/reference_noise.hpp"
#include "magnetometer_insitu_calibration/ros/live_window.hpp"

#include <cstddef>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// The windows of `channels` test instruments, grouped by start (UNIX s). A channel's completed
/// window waits until every channel has completed the window of that start, or any channel has
/// completed a later one; the group is then released, oldest start first. So a window waits at
/// most one ~step for its mates: when an instrument is silent, or its window had no sample, the
/// others go without it (their `mate` is empty and the window is estimated without the hat).
class CoincidentWindows {
 public:
  explicit CoincidentWindows(std::size_t channels);

  struct Released {
    std::size_t channel = 0;
    WindowData window;
    /// Another instrument's window of the same start (the next channel in order that has one),
    /// its paired record (reference frame / its own test frame, nT, NaN = missing); null: none.
    std::shared_ptr<const PairedRecord> mate;
    std::size_t mate_channel = 0;
  };

  /// Adds the window `channel` completed; returns the windows released by it (every channel's
  /// window of a released start, in channel order, oldest start first).
  std::vector<Released> add(std::size_t channel, WindowData&& window);
  /// Windows waiting for their mates.
  std::size_t pending() const;
  /// Forgets a channel's waiting windows and its newest start (after its stamps went back);
  /// the other channels' waiting windows are released by their next window.
  void reset(std::size_t channel);

 private:
  std::size_t channels_;
  std::map<double, std::vector<std::optional<WindowData>>> pending_;  ///< by start, one slot per channel
  std::vector<double> newest_start_;                                 ///< per channel, -inf before any
};

/// The worker's estimate of one window with the hat: the reference's noise identified from
/// `window` and `mate`, each despiked and its short NaN runs (up to 5 epochs) bridged by straight
/// lines as offline (identify_reference_noise over the estimator's configured band, up to 4 bins,
/// and 6 bins above it to 0.25 / period;
/// `mate_name` names the mate in the text); when identified, the window is estimated with it as
/// the given reference noise (EivCorrection::kGiven; the window's eiv text says "three-cornered
/// hat with <mate_name>"), else with `estimator` as it is (no correction). `noise` gets the hat's
/// result (every instrument's PSD per bin, the reference's fitted levels); its text says what
/// was identified or why nothing was (without a mate: "no window of another test instrument").
/// `estimator`'s settings must be robust with eiv given and no reference noise of their own.
WindowResult estimate_window_with_hat(WindowData window, const PairedRecord* mate, const std::string& mate_name,
                                      WindowEstimator& estimator, const WindowGapRule& rule, IdentifiedNoise& noise);

/// The worker's estimate of one window with the reference's noise from the pair itself (no third
/// instrument, no figure; ~pair_noise): the window estimated with `estimator` as it is, then the
/// noise identified from the window's despiked, bridged pair (as for the hat) above the band
/// through that first estimate and its response model (identify_reference_noise_from_pair); when
/// identified, the window estimated again with it as the given reference noise (its eiv text says
/// "from the pair above the band"), else the first estimate is the result. `noise` gets the
/// identification's result and text. `estimator`'s settings as for the hat.
WindowResult estimate_window_with_pair_noise(WindowData window, WindowEstimator& estimator, const WindowGapRule& rule,
                                             IdentifiedNoise& noise);

}  // namespace magnetometer_insitu_calibration
