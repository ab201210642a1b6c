// calibration_node's three-cornered hat without ROS: see live_three_cornered_hat.hpp.
#include "magnetometer_insitu_calibration/ros/live_three_cornered_hat.hpp"


#include <cmath>
#include <exception>
#include <limits>

namespace magnetometer_insitu_calibration {

CoincidentWindows::CoincidentWindows(std::size_t channels)
    : channels_(channels), newest_start_(channels, -std::numeric_limits<double>::infinity()) {}

std::size_t CoincidentWindows::pending() const {
  std::size_t count = 0;
  for (const auto& [start, slots] : pending_)
    for (const auto& slot : slots) count += slot.has_value() ? 1 : 0;
  return count;
}

void CoincidentWindows::reset(std::size_t channel) {
  newest_start_.at(channel) = -std::numeric_limits<double>::infinity();
  for (auto it = pending_.begin(); it != pending_.end();) {
    it->second[channel].reset();
    bool empty = true;
    for (const auto& slot : it->second) empty = empty && !slot.has_value();
    it = empty ? pending_.erase(it) : std::next(it);
  }
}

std::vector<CoincidentWindows::Released> CoincidentWindows::add(std::size_t channel, WindowData&& window) {
  const double start = window.start_s;
  auto& slots = pending_[start];
  slots.resize(channels_);
  slots.at(channel) = std::move(window);
  newest_start_[channel] = std::max(newest_start_[channel], start);
  double newest_any = -std::numeric_limits<double>::infinity();
  for (const double s : newest_start_) newest_any = std::max(newest_any, s);

  std::vector<Released> out;
  while (!pending_.empty()) {
    auto group = pending_.begin();
    bool complete = true;
    for (std::size_t c = 0; c < channels_; ++c) complete = complete && group->second[c].has_value();
    if (!complete && !(newest_any > group->first)) break;  // wait for the missing ones
    // Each window's record, shared by the mates that use it.
    std::vector<std::shared_ptr<const PairedRecord>> records(channels_);
    for (std::size_t c = 0; c < channels_; ++c) {
      if (group->second[c]) records[c] = std::make_shared<const PairedRecord>(group->second[c]->paired);
    }
    for (std::size_t c = 0; c < channels_; ++c) {
      if (!group->second[c]) continue;
      Released r;
      r.channel = c;
      r.window = std::move(*group->second[c]);
      for (std::size_t k = 1; k < channels_; ++k) {  // the next channel in order with a window
        const std::size_t m = (c + k) % channels_;
        if (records[m]) {
          r.mate = records[m];
          r.mate_channel = m;
          break;
        }
      }
      out.push_back(std::move(r));
    }
    pending_.erase(group);
  }
  return out;
}

namespace {

/// Runs of at most this many epochs with a NaN (spikes removed) are bridged for the hat.
constexpr Eigen::Index kLongestBridgedRun = 5;

/// A window's pair as the offline pipeline prepares it before the hat sees it: spikes removed
/// from both records (despike_window: the offline settings, not at the window's edges), an epoch with a NaN in any of the six
/// values NaN in all six, and runs of up to kLongestBridgedRun such epochs replaced by the
/// straight line between their neighbours in every column (as regularize_and_fill does; longer
/// gaps stay NaN and end the hat's run of shared epochs). Without this, one 50 nT spike a
/// hour makes the hat's reference noise 3x the truth (monte_carlo_node_hat, MC_SPIKES=20).
PairedRecord despiked(PairedRecord p) {
  const DespikeSettings settings;
  despike_window(p.reference_nT, settings);
  despike_window(p.test_nT, settings);
  const Eigen::Index n = p.reference_nT.rows();
  std::vector<char> bad(static_cast<std::size_t>(n), 0);
  for (Eigen::Index i = 0; i < n; ++i) {
    bad[static_cast<std::size_t>(i)] = !(p.reference_nT.row(i).allFinite() && p.test_nT.row(i).allFinite());
  }
  for (Eigen::Index i = 0; i < n;) {
    if (!bad[static_cast<std::size_t>(i)]) {
      ++i;
      continue;
    }
    Eigen::Index j = i;
    while (j < n && bad[static_cast<std::size_t>(j)]) ++j;  // [i, j) bad
    const bool bridged = i > 0 && j < n && j - i <= kLongestBridgedRun;
    for (Eigen::Index k = i; k < j; ++k) {
      const double w = bridged ? static_cast<double>(k - i + 1) / static_cast<double>(j - i + 1) : 0.0;
      for (Readings* m : {&p.reference_nT, &p.test_nT}) {
        (*m).row(k) = bridged ? Eigen::RowVector3d((1.0 - w) * (*m).row(i - 1) + w * (*m).row(j))
                              : Eigen::RowVector3d::Constant(std::numeric_limits<double>::quiet_NaN());
      }
    }
    i = j;
  }
  return p;
}

}  // namespace

WindowResult estimate_window_with_hat(WindowData window, const PairedRecord* mate, const std::string& mate_name,
                                      WindowEstimator& estimator, const WindowGapRule& rule, IdentifiedNoise& noise) {
  const EstimatorSettings& settings = estimator.settings();
  noise = IdentifiedNoise{};
  if (mate == nullptr) {
    noise.text = "reference noise not identified: no window of another test instrument for these epochs";
  } else {
    try {
      noise = identify_reference_noise(despiked(window.paired), despiked(*mate), window.period_s, settings.band_low_hz,
                                       settings.band_high_hz, 4, mate_name);
    } catch (const std::exception& e) {
      noise = IdentifiedNoise{};
      noise.text = std::string("reference noise not identified by the three-cornered hat with ") + mate_name +
                        ": " + e.what();
    }
  }
  if (!noise.identified) return estimate_window(std::move(window), estimator, rule);
  WindowEstimator identified(with_identified_noise(settings, noise, "three-cornered hat with " + mate_name));  // FFTW_ESTIMATE plans: microseconds per window
  return estimate_window(std::move(window), identified, rule);
}

WindowResult estimate_window_with_pair_noise(WindowData window, WindowEstimator& estimator, const WindowGapRule& rule,
                                             IdentifiedNoise& noise) {
  const EstimatorSettings& settings = estimator.settings();
  const PairedRecord paired = despiked(window.paired);
  const double period = window.period_s;
  WindowResult first = estimate_window(window, estimator, rule);
  try {
    noise = identify_reference_noise_from_pair(paired.reference_nT, paired.test_nT, period, first.estimate,
                                               first.response_model, settings.band_high_hz);
  } catch (const std::exception& e) {
    noise = IdentifiedNoise{};
    noise.text = std::string("reference noise not identified from the pair: ") + e.what();
  }
  if (!noise.identified) return first;
  WindowEstimator identified(with_identified_noise(settings, noise, "from the pair above the band"));
  return estimate_window(std::move(window), identified, rule);
}

}  // namespace magnetometer_insitu_calibration
