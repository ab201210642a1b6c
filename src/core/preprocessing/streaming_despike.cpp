// despike() on a stream: see streaming_despike.hpp. The rule and its reasons are despike.hpp's;
// this file computes the same quantities as they become known, with the same arithmetic.
#include "magnetometer_insitu_calibration/preprocessing/streaming_despike.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace magnetometer_insitu_calibration {

namespace {

constexpr double kMadToSigma = 1.4826;

/// The median of values[0 .. count) (reordered), as despike()'s running median gives it: the
/// middle value, or half the sum of the two middle values; NaN when count is 0.
double median_of(std::vector<double>& values, std::size_t count) {
  if (count == 0) return std::numeric_limits<double>::quiet_NaN();
  const auto begin = values.begin();
  const std::size_t upper = count / 2;
  std::nth_element(begin, begin + static_cast<std::ptrdiff_t>(upper), begin + static_cast<std::ptrdiff_t>(count));
  const double high = values[upper];
  if (count % 2 == 1) return high;
  const double low = *std::max_element(begin, begin + static_cast<std::ptrdiff_t>(upper));
  return 0.5 * (low + high);
}

}  // namespace

StreamingDespiker::StreamingDespiker(const DespikeSettings& settings)
    : settings_((settings.validate(), settings)),
      w_(settings.half_window),
      capacity_(4 * settings.half_window + 2),
      time_s_(capacity_),
      x_(capacity_),
      median_(capacity_),
      residual_(capacity_),
      count_(capacity_),
      scratch_(2 * settings.half_window + 1) {}

void StreamingDespiker::reset() {
  received_ = medians_ = decided_ = 0;
}

/// Median of the finite x over [j - w, j + w] clipped to [0, last], their count, and j's residual.
void StreamingDespiker::compute_median(std::size_t j, std::size_t last) {
  const std::size_t from = j >= w_ ? j - w_ : 0, to = std::min(last, j + w_);
  for (int c = 0; c < 3; ++c) {
    std::size_t count = 0;
    for (std::size_t k = from; k <= to; ++k) {
      const double v = x_[slot(k)](c);
      if (std::isfinite(v)) scratch_[count++] = v;
    }
    median_[slot(j)](c) = median_of(scratch_, count);
    count_[slot(j)](c) = count;
    residual_[slot(j)](c) = x_[slot(j)](c) - median_[slot(j)](c);  // NaN where x is NaN
  }
}

StreamingDespiker::Sample StreamingDespiker::decide(std::size_t i, std::size_t last) {
  Sample out{time_s_[slot(i)], x_[slot(i)]};
  const std::size_t from = i >= w_ ? i - w_ : 0, to = std::min(last, i + w_);
  const std::size_t lag = std::min({w_, i, last - i});
  for (int c = 0; c < 3; ++c) {
    const double residual = residual_[slot(i)](c);
    if (!std::isfinite(residual) || count_[slot(i)](c) < 3) continue;
    std::size_t count = 0;
    for (std::size_t j = from; j <= to; ++j) {
      const double r = std::abs(residual_[slot(j)](c));
      if (std::isfinite(r)) scratch_[count++] = r;
    }
    const double mad = median_of(scratch_, count);
    double curvature = 0.0;
    if (lag > 0) {
      const double d2 = std::abs(median_[slot(i - lag)](c) - 2.0 * median_[slot(i)](c) + median_[slot(i + lag)](c));
      curvature = std::isfinite(d2) ? d2 : 0.0;
    }
    const double limit = std::max({settings_.threshold * kMadToSigma * mad, settings_.min_threshold_nT, curvature});
    if (std::abs(residual) > limit) {
      out.value_nT(c) = std::numeric_limits<double>::quiet_NaN();
      ++spikes_;
    }
  }
  return out;
}

bool StreamingDespiker::push(double time_s, const Eigen::Vector3d& value_nT, Sample& out) {
  const std::size_t k = received_++;
  time_s_[slot(k)] = time_s;
  x_[slot(k)] = value_nT;
  if (k >= w_) {  // sample k - w's median window is complete
    compute_median(k - w_, k);
    medians_ = k - w_ + 1;
  }
  if (k < 2 * w_) return false;
  out = decide(k - 2 * w_, k);  // its neighbours' residuals and medians are known
  decided_ = k - 2 * w_ + 1;
  return true;
}

std::vector<StreamingDespiker::Sample> StreamingDespiker::flush() {
  std::vector<Sample> out;
  if (received_ == 0) return out;
  const std::size_t last = received_ - 1;
  for (std::size_t j = medians_; j <= last; ++j) compute_median(j, last);
  for (std::size_t i = decided_; i <= last; ++i) out.push_back(decide(i, last));
  reset();
  return out;
}

}  // namespace magnetometer_insitu_calibration
