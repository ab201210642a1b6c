// The live buffers of calibration: see live_windows.hpp.
#include "magnetometer_insitu_calibration/pipeline/live_windows.hpp"

#include "magnetometer_insitu_calibration/common/time_steps.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>

namespace magnetometer_insitu_calibration {

StreamMonitor::Jump StreamMonitor::observe(double stamp_s, double arrival_s, const std::string& frame,
                                           double threshold_s) {
  ++messages;
  last_arrival_s = arrival_s;
  frame_id = frame;
  const double step = stamp_s - previous_stamp_s_;
  if (messages > 1 && step > 0.0 && step < threshold_s) {
    steps_.push_back(step);
    if (steps_.size() > kPeriodSteps) steps_.pop_front();
  }
  previous_stamp_s_ = stamp_s;
  if (messages == 1 || !std::isfinite(newest_stamp_s)) {
    newest_stamp_s = stamp_s;
    keep_stamp(stamp_s);
    return Jump::kNone;
  }
  if (stamp_s < newest_stamp_s - threshold_s) {
    if (!behind_) {  // maybe one stray stamp: wait for the next sample
      behind_ = true;
      ++stray;
      return Jump::kNone;
    }
    behind_ = false;  // two in a row: the clock was set back
    --stray;
    ++jumps_backward;
    newest_stamp_s = stamp_s;
    keep_stamp(stamp_s);
    return Jump::kBackward;
  }
  behind_ = false;
  keep_stamp(stamp_s);
  const Jump jump = stamp_s > newest_stamp_s + threshold_s ? Jump::kForward : Jump::kNone;
  if (jump == Jump::kForward) ++jumps_forward;
  newest_stamp_s = std::max(newest_stamp_s, stamp_s);
  return jump;
}

double StreamMonitor::silence_s(double now_s, double since_s) const {
  return now_s - (messages > 0 ? last_arrival_s : since_s);
}

void StreamMonitor::keep_stamp(double stamp_s) {
  if (!std::isfinite(stamp_s)) return;
  stamps_.push_back(stamp_s);
  if (stamps_.size() > kPeriodSteps) stamps_.pop_front();
}

double StreamMonitor::stamp_phase_s(double period_s) const {
  if (stamps_.size() < kMinPeriodSteps) return std::numeric_limits<double>::quiet_NaN();
  return magnetometer_insitu_calibration::stamp_phase_s(std::vector<double>(stamps_.begin(), stamps_.end()), period_s);
}

double StreamMonitor::measured_period_s() const {
  if (steps_.size() < kMinPeriodSteps) return std::numeric_limits<double>::quiet_NaN();
  std::vector<double> steps(steps_.begin(), steps_.end());
  const auto middle = steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2);
  std::nth_element(steps.begin(), middle, steps.end());
  return *middle;
}

std::string StreamMonitor::period_problem(double nominal_period_s) const {
  const double measured = measured_period_s();
  if (!std::isfinite(measured) || std::abs(measured - nominal_period_s) <= 0.1 * nominal_period_s) return "";
  char text[96];
  std::snprintf(text, sizeof text, "stamps step by %.4g s, not %.4g s", measured, nominal_period_s);
  return text;
}

SlidingWindowBuffer::SlidingWindowBuffer(double window_s, double step_s, double period_s)
    : window_s_(window_s),
      step_s_(step_s),
      period_s_(period_s),
      expected_samples_(static_cast<std::size_t>(std::max(1LL, std::llround(window_s / period_s)))) {}

void SlidingWindowBuffer::reset() {
  buffer_.clear();
  started_ = false;
}

std::vector<WindowRecords> SlidingWindowBuffer::push(double time_s, const Eigen::Vector3d& reference_nT,
                                                  const Eigen::Vector3d& test_nT) {
  std::vector<WindowRecords> done;
  if (!std::isfinite(time_s) || (started_ && time_s <= last_time_s_)) {
    ++out_of_order_;
    return done;
  }
  const double half = 0.5 * period_s_;
  if (!started_) {
    next_start_ = std::ceil((time_s - half) / step_s_) * step_s_;
    started_ = true;
  }
  last_time_s_ = time_s;
  // Complete every window whose end this sample has reached.
  while (time_s >= next_start_ + window_s_ - half) {
    WindowRecords w = copy_window(next_start_);
    if (w.paired.size() == 0) {
      ++skipped_empty_;
    } else {
      ++emitted_;
      done.push_back(std::move(w));
    }
    next_start_ += step_s_;
    // After a long silence or jump, go straight to the first window that can hold data.
    const double first_data = buffer_.empty() ? time_s : std::min(time_s, buffer_.front().time_s);
    if (next_start_ + window_s_ - half <= first_data) {
      const double skip_to = std::ceil((first_data - window_s_ + half) / step_s_) * step_s_;
      if (skip_to > next_start_) {
        skipped_empty_ += static_cast<std::size_t>(std::llround((skip_to - next_start_) / step_s_));
        next_start_ = skip_to;
      }
    }
    while (!buffer_.empty() && buffer_.front().time_s < next_start_ - half) buffer_.pop_front();
  }
  buffer_.push_back(PairedSample{time_s, reference_nT, test_nT});
  return done;
}

WindowRecords SlidingWindowBuffer::copy_window(double start_s) const {
  const double half = 0.5 * period_s_;
  const double low = start_s - half, high = start_s + window_s_ - half;
  auto first = std::lower_bound(buffer_.begin(), buffer_.end(), low,
                                [](const PairedSample& s, double t) { return s.time_s < t; });
  auto last = std::lower_bound(first, buffer_.end(), high,
                               [](const PairedSample& s, double t) { return s.time_s < t; });
  WindowRecords w;
  w.start_s = start_s;
  w.period_s = period_s_;
  w.expected_samples = expected_samples_;
  const auto n = static_cast<Eigen::Index>(std::distance(first, last));
  w.paired.time_s.reserve(static_cast<std::size_t>(n));
  w.paired.reference_nT.resize(n, 3);
  w.paired.test_nT.resize(n, 3);
  Eigen::Index row = 0;
  for (auto it = first; it != last; ++it, ++row) {
    w.paired.time_s.push_back(it->time_s);
    w.paired.reference_nT.row(row) = it->reference_nT.transpose();
    w.paired.test_nT.row(row) = it->test_nT.transpose();
  }
  return w;
}

void TemperatureBuffer::push(double time_s, double value_C) {
  if (!std::isfinite(time_s) || (!samples_.empty() && time_s <= samples_.back().first)) {
    ++out_of_order_;
    return;
  }
  samples_.emplace_back(time_s, value_C);
  while (samples_.front().first < time_s - span_s_) samples_.pop_front();
}

TemperatureSamples TemperatureBuffer::copy(double low_s, double high_s) const {
  TemperatureSamples out;
  out.recorded = true;
  for (const auto& sample : samples_) {
    if (sample.first < low_s) continue;
    if (sample.first > high_s) break;
    out.time_s.push_back(sample.first);
    out.value_C.push_back(sample.second);
  }
  return out;
}

void TemperatureBuffer::drop_before(double time_s) {
  while (!samples_.empty() && samples_.front().first < time_s) samples_.pop_front();
}

namespace {

/// A test's samples at the epochs of its window where its pair is complete (its own frame, nT),
/// NaN elsewhere: that test as another's third instrument. The test is paired with the
/// reference in its own right (it is calibrated too); an epoch its reference lacks is one the
/// hat cannot use.
VectorRecord complete_test_samples(const PairedRecord& paired) {
  VectorRecord out;
  out.time_s = paired.time_s;
  out.values_nT = paired.test_nT;
  for (Eigen::Index r = 0; r < out.values_nT.rows(); ++r) {
    if (!paired.reference_nT.row(r).allFinite()) out.values_nT.row(r).setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  return out;
}

}  // namespace

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

std::vector<CoincidentWindows::Released> CoincidentWindows::add(std::size_t channel, WindowRecords&& window) {
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
    // Each window's test samples of its complete epochs, shared by the mates that use it as
    // their third.
    std::vector<std::shared_ptr<const VectorRecord>> records(channels_);
    for (std::size_t c = 0; c < channels_; ++c) {
      if (group->second[c]) records[c] = std::make_shared<const VectorRecord>(complete_test_samples(group->second[c]->paired));
    }
    for (std::size_t c = 0; c < channels_; ++c) {
      if (!group->second[c]) continue;
      Released r;
      r.channel = c;
      r.window = std::move(*group->second[c]);
      for (std::size_t k = 1; k < channels_; ++k) {  // the next channel in order with a window
        const std::size_t m = (c + k) % channels_;
        if (records[m]) {
          r.window.third = records[m];
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

}  // namespace magnetometer_insitu_calibration
