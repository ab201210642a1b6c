// Sliding window over the live paired stream, and the estimate of one window.
#include "magnetometer_insitu_calibration/ros/live_window.hpp"

#include "magnetometer_insitu_calibration/pipeline/temperature_channel.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace magnetometer_insitu_calibration {

StreamMonitor::Jump StreamMonitor::observe(double stamp_s, double arrival_s, const std::string& frame,
                                           double threshold_s) {
  ++messages;
  last_arrival_s = arrival_s;
  frame_id = frame;
  if (messages == 1 || !std::isfinite(newest_stamp_s)) {
    newest_stamp_s = stamp_s;
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
    return Jump::kBackward;
  }
  behind_ = false;
  const Jump jump = stamp_s > newest_stamp_s + threshold_s ? Jump::kForward : Jump::kNone;
  if (jump == Jump::kForward) ++jumps_forward;
  newest_stamp_s = std::max(newest_stamp_s, stamp_s);
  return jump;
}

double StreamMonitor::silence_s(double now_s, double since_s) const {
  return now_s - (messages > 0 ? last_arrival_s : since_s);
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

std::vector<WindowData> SlidingWindowBuffer::push(double time_s, const Eigen::Vector3d& reference_nT,
                                                  const Eigen::Vector3d& test_nT) {
  std::vector<WindowData> done;
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
    WindowData w = copy_window(next_start_);
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

WindowData SlidingWindowBuffer::copy_window(double start_s) const {
  const double half = 0.5 * period_s_;
  const double low = start_s - half, high = start_s + window_s_ - half;
  auto first = std::lower_bound(buffer_.begin(), buffer_.end(), low,
                                [](const PairedSample& s, double t) { return s.time_s < t; });
  auto last = std::lower_bound(first, buffer_.end(), high,
                               [](const PairedSample& s, double t) { return s.time_s < t; });
  WindowData w;
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
  out.subscribed = true;
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

Eigen::VectorXd temperature_on_grid(const TemperatureSamples& samples, const std::vector<double>& at, double max_gap_s) {
  const auto n = static_cast<Eigen::Index>(at.size());
  Eigen::VectorXd out = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::quiet_NaN());
  if (samples.time_s.empty() || n == 0) return out;
  out = interpolate_channel(samples.time_s, samples.value_C, at, max_gap_s);
  // The first and last finite samples hold over at most max_gap_s beyond them.
  std::size_t first = 0, last = samples.time_s.size();
  while (first < samples.time_s.size() && !std::isfinite(samples.value_C[first])) ++first;
  while (last > first && !std::isfinite(samples.value_C[last - 1])) --last;
  if (first >= last) return out;
  const double t_first = samples.time_s[first], t_last = samples.time_s[last - 1];
  for (Eigen::Index i = 0; i < n; ++i) {
    const double t = at[static_cast<std::size_t>(i)];
    if (t < t_first && t_first - t <= max_gap_s) out(i) = samples.value_C[first];
    if (t > t_last && t - t_last <= max_gap_s) out(i) = samples.value_C[last - 1];
  }
  return out;
}

namespace {

constexpr double kSecondsPerDay = 86400.0;

using EstimateFunction = WindowEstimateFunction;

// Offset of the window (see WindowResult::offset_end_nT for the model and the interval).
void estimate_offset(WindowResult& r, const PairedRecord& paired) {
  const WindowEstimate& e = r.estimate;
  const auto rows = paired.reference_nT.rows();
  if (rows < 2 || !e.n.allFinite()) return;
  double t_centre = 0.0;
  for (double t : paired.time_s) t_centre += t;
  t_centre /= static_cast<double>(paired.time_s.size());
  const Eigen::Vector3d mean_r = paired.reference_nT.colwise().mean().transpose();
  const Eigen::Vector3d mean_t = paired.test_nT.colwise().mean().transpose();
  const Eigen::Vector3d trend_per_s = e.trend_nT_per_day / kSecondsPerDay;
  const Eigen::Vector3d d = mean_t - e.n.transpose() * mean_r;
  // Time-domain residual about the fitted model.
  Eigen::Vector3d sum2 = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < rows; ++i) {
    const Eigen::Vector3d residual = paired.test_nT.row(i).transpose() - e.n.transpose() * paired.reference_nT.row(i).transpose() -
                                     d - trend_per_s * (paired.time_s[static_cast<std::size_t>(i)] - t_centre);
    sum2 += residual.cwiseAbs2();
  }
  const double count = static_cast<double>(rows);
  const double dt = r.end_s - t_centre;
  r.offset_centre_nT = d;
  r.reference_mean_nT = mean_r;
  r.offset_end_nT = d + trend_per_s * dt;
  for (int l = 0; l < 3; ++l) {
    Eigen::Matrix3d column_covariance;
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) column_covariance(a, b) = e.n_covariance(vec_index(a, l), vec_index(b, l));
    }
    const double trend_se_per_s = e.trend_stderr_nT_per_day(l) / kSecondsPerDay;
    const double variance = mean_r.dot(column_covariance * mean_r) + sum2(l) / count / count +
                            dt * dt * trend_se_per_s * trend_se_per_s;
    r.offset_end_ci95_nT(l) = 1.959963984540054 * std::sqrt(std::max(0.0, variance));
  }
}

// The temperature terms of the window (see estimate_window): fitted on the grid, removed from
// window.paired.test_nT in place when fitted.
void fit_window_temperature(WindowResult& r, WindowData& window, const EstimateFunction& estimate,
                            const EstimatorSettings* settings, const WindowGapRule& rule) {
  r.temperature_samples = window.temperature.time_s.size();
  if (!window.temperature.subscribed) {
    r.temperature.text = "no temperature topic: estimated without temperature terms";
    return;
  }
  if (settings == nullptr) {
    r.temperature.text = "temperature terms need the window estimator (not the plain FdWlseEstimator)";
    return;
  }
  if (window.temperature.time_s.empty()) {
    r.temperature.text = "no temperature sample in the window: estimated without temperature terms";
    return;
  }
  const Eigen::VectorXd theta = temperature_on_grid(window.temperature, window.paired.time_s, rule.temperature_max_gap_s);
  r.temperature_known = theta.size() > 0 && theta.allFinite();
  r.temperature = with_temperature_terms(estimate, *settings, rule.temperature, window.paired.reference_nT,
                                         window.paired.test_nT, theta, window.period_s, r.estimate);
  if (r.temperature_known && !r.temperature.fitted) {  // as fit_temperature states them when it gets that far
    r.temperature.reference_C = theta.mean();
    r.temperature.range_C = theta.maxCoeff() - theta.minCoeff();
  }
}

WindowResult estimate_window_with(WindowData window, const EstimateFunction& estimate, const EstimatorSettings* settings,
                                  const WindowGapRule& rule) {
  WindowResult r;
  r.start_s = window.start_s;
  r.end_s = window.end_s();
  r.expected_samples = window.expected_samples;
  if (rule.despike) {  // as offline: spikes become NaN, then filled with the gaps at the same epochs
    r.spikes = despike_window(window.paired.reference_nT, rule.despike_settings) +
               despike_window(window.paired.test_nT, rule.despike_settings);
  }
  const GapReport gaps = regularize_and_fill(window.paired, window.period_s, rule.gaps);
  const double period = window.period_s;
  const auto epoch = [&](double t) { return std::llround((t - window.start_s) / period); };
  const long long first = std::max(0LL, epoch(window.paired.time_s.front()));
  const long long last = std::min<long long>(static_cast<long long>(window.expected_samples) - 1,
                                             epoch(window.paired.time_s.back()));
  r.leading_missing = static_cast<std::size_t>(first);
  r.trailing_missing = static_cast<std::size_t>(std::max(0LL, static_cast<long long>(window.expected_samples) - 1 - last));
  r.interpolated = gaps.filled_samples;
  const double edge_gap_s = static_cast<double>(std::max(r.leading_missing, r.trailing_missing)) * period;
  r.long_gap = !gaps.long_gaps.empty() || edge_gap_s > rule.gaps.max_fill_s;
  r.estimate = estimate(window.paired.reference_nT, window.paired.test_nT, period);
  Readings recorded, before_temperature;  // kept only when a modelled filter is removed
  // As offline: the bands' gains corrected for an identified reference noise (a figure, the hat).
  const RelativeResponseSettings response =
      settings != nullptr ? with_identified_reference_noise({}, *settings) : RelativeResponseSettings{};
  if (!rule.response_model) {
    r.response_model.text = "response model off (~response_model false)";
  } else if (settings == nullptr) {
    r.response_model.text = "response model needs the window estimator (not the plain FdWlseEstimator)";
  } else {
    recorded = window.paired.test_nT;
    r.response_model = with_response_model(estimate, window.paired.reference_nT, window.paired.test_nT, period, response,
                                           rule.model, r.estimate);
    if (r.response_model.applied) before_temperature = window.paired.test_nT;
  }
  fit_window_temperature(r, window, estimate, settings, rule);
  // Of the test as recorded (a modelled filter shows), without the temperature terms.
  const Readings shown = r.response_model.applied
                             ? Readings(recorded - (before_temperature - window.paired.test_nT))
                             : window.paired.test_nT;
  r.relative_response = relative_response(window.paired.reference_nT, shown, r.estimate.n, period, response);
  const double band_low = std::isfinite(r.estimate.band_low_hz) ? r.estimate.band_low_hz : 0.0;
  const double band_high = std::isfinite(r.estimate.band_high_hz) ? r.estimate.band_high_hz : 0.5 / period;
  r.response = summarise_response(r.relative_response, band_low, band_high);
  estimate_offset(r, window.paired);
  const double fraction = static_cast<double>(r.missing()) / static_cast<double>(window.expected_samples);
  if (r.long_gap || fraction > rule.max_filled_fraction) {
    // Missing data is the cause to report, even when the shortened window also failed one of
    // the estimator's rules (whose text is kept).
    std::ostringstream text;
    text << r.missing() << " of " << window.expected_samples << " samples interpolated or missing";
    if (r.long_gap) text << ", a gap longer than " << rule.gaps.max_fill_s << " s";
    if (r.estimate.quality != Quality::kOk) text << "; also " << r.estimate.quality_text;
    r.estimate.quality = Quality::kGaps;
    r.estimate.quality_text = text.str();
  }
  return r;
}

}  // namespace

WindowResult estimate_window(WindowData window, FdWlseEstimator& estimator, const WindowGapRule& rule) {
  return estimate_window_with(
      std::move(window),
      [&](const Eigen::Ref<const Readings>& r, const Eigen::Ref<const Readings>& t, double p) {
        return estimator.estimate(r, t, p);
      },
      nullptr, rule);
}

WindowResult estimate_window(WindowData window, WindowEstimator& estimator, const WindowGapRule& rule) {
  return estimate_window_with(
      std::move(window),
      [&](const Eigen::Ref<const Readings>& r, const Eigen::Ref<const Readings>& t, double p) {
        return estimator.estimate(r, t, p);
      },
      &estimator.settings(), rule);
}

std::size_t despike_window(Readings& values, const DespikeSettings& settings) {
  const Readings original = values;
  despike(values, settings);
  const Eigen::Index n = values.rows();
  const Eigen::Index edge = std::min<Eigen::Index>(n, 2 * static_cast<Eigen::Index>(settings.half_window));
  std::size_t flagged = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) {
      if (std::isnan(values(i, c)) && !std::isnan(original(i, c))) {
        if (i < edge || i >= n - edge) {
          values(i, c) = original(i, c);  // no context at the window's edge: not judged here
        } else {
          ++flagged;
        }
      }
    }
  }
  return flagged;
}

}  // namespace magnetometer_insitu_calibration
