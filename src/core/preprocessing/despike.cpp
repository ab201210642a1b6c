#include "magnetometer_insitu_calibration/preprocessing/despike.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace magnetometer_insitu_calibration {
namespace {

/// Median of a sliding set of at most `capacity` values, each held in a slot (0..capacity-1).
/// Two indexed binary heaps: `low_` (max-heap) holds the smaller half, `high_` (min-heap) the
/// larger half, |low| = |high| or |high| + 1. Insert and erase by slot cost O(log capacity),
/// with no allocation after construction.
class SlidingMedian {
 public:
  explicit SlidingMedian(std::size_t capacity)
      : value_(capacity, 0.0), heap_of_(capacity, kNone), position_(capacity, 0) {
    low_.reserve(capacity);
    high_.reserve(capacity);
  }

  std::size_t size() const { return low_.size() + high_.size(); }

  void insert(std::size_t slot, double value) {
    value_[slot] = value;
    if (low_.empty() || value <= value_[low_.front()]) {
      push(kLow, slot);
    } else {
      push(kHigh, slot);
    }
    rebalance();
  }

  /// Removes the value in `slot` if it holds one.
  void erase(std::size_t slot) {
    const int heap = heap_of_[slot];
    if (heap == kNone) return;
    std::vector<std::size_t>& h = heap == kLow ? low_ : high_;
    const std::size_t pos = position_[slot];
    const std::size_t last = h.back();
    h.pop_back();
    heap_of_[slot] = kNone;
    if (pos < h.size()) {
      h[pos] = last;
      position_[last] = pos;
      sift_up(heap, pos);
      sift_down(heap, position_[last]);
    }
    rebalance();
  }

  /// Gives `slot` a new value (inserting or erasing when the old or new value is not finite).
  void replace(std::size_t slot, double value) {
    const int heap = heap_of_[slot];
    if (heap == kNone) {
      if (std::isfinite(value)) insert(slot, value);
      return;
    }
    if (!std::isfinite(value)) {
      erase(slot);
      return;
    }
    value_[slot] = value;
    sift_up(heap, position_[slot]);
    sift_down(heap, position_[slot]);
    // Restore max(low) <= min(high) by exchanging the two tops if needed.
    if (!low_.empty() && !high_.empty() && value_[low_.front()] > value_[high_.front()]) {
      const std::size_t a = low_.front(), b = high_.front();
      place(kLow, 0, b);
      heap_of_[b] = kLow;
      place(kHigh, 0, a);
      heap_of_[a] = kHigh;
      sift_down(kLow, 0);
      sift_down(kHigh, 0);
    }
  }

  double median() const {
    if (low_.empty()) return std::numeric_limits<double>::quiet_NaN();
    if (low_.size() > high_.size()) return value_[low_.front()];
    return 0.5 * (value_[low_.front()] + value_[high_.front()]);
  }

 private:
  static constexpr int kNone = -1, kLow = 0, kHigh = 1;

  /// True when slot a belongs above slot b in the given heap.
  bool above(int heap, std::size_t a, std::size_t b) const {
    return heap == kLow ? value_[a] > value_[b] : value_[a] < value_[b];
  }

  void place(int heap, std::size_t pos, std::size_t slot) {
    (heap == kLow ? low_ : high_)[pos] = slot;
    position_[slot] = pos;
  }

  void sift_up(int heap, std::size_t pos) {
    std::vector<std::size_t>& h = heap == kLow ? low_ : high_;
    const std::size_t slot = h[pos];
    while (pos > 0) {
      const std::size_t parent = (pos - 1) / 2;
      if (!above(heap, slot, h[parent])) break;
      place(heap, pos, h[parent]);
      pos = parent;
    }
    place(heap, pos, slot);
  }

  void sift_down(int heap, std::size_t pos) {
    std::vector<std::size_t>& h = heap == kLow ? low_ : high_;
    const std::size_t slot = h[pos];
    const std::size_t n = h.size();
    while (true) {
      std::size_t child = 2 * pos + 1;
      if (child >= n) break;
      if (child + 1 < n && above(heap, h[child + 1], h[child])) ++child;
      if (!above(heap, h[child], slot)) break;
      place(heap, pos, h[child]);
      pos = child;
    }
    place(heap, pos, slot);
  }

  void push(int heap, std::size_t slot) {
    std::vector<std::size_t>& h = heap == kLow ? low_ : high_;
    h.push_back(slot);
    heap_of_[slot] = heap;
    position_[slot] = h.size() - 1;
    sift_up(heap, h.size() - 1);
  }

  /// Removes and returns the top slot of a non-empty heap.
  std::size_t pop(int heap) {
    std::vector<std::size_t>& h = heap == kLow ? low_ : high_;
    const std::size_t top = h.front();
    const std::size_t last = h.back();
    h.pop_back();
    heap_of_[top] = kNone;
    if (!h.empty()) {
      place(heap, 0, last);
      sift_down(heap, 0);
    }
    return top;
  }

  void rebalance() {
    while (low_.size() > high_.size() + 1) push(kHigh, pop(kLow));
    while (high_.size() > low_.size()) push(kLow, pop(kHigh));
  }

  std::vector<double> value_;
  std::vector<int> heap_of_;
  std::vector<std::size_t> position_;
  std::vector<std::size_t> low_, high_;
};

/// out[i] = median of the finite in[j], |j - i| <= w (NaN when none).
void running_median(const std::vector<double>& in, std::size_t w, std::vector<double>& out,
                    std::vector<std::size_t>& count, SlidingMedian& window) {
  const std::size_t n = in.size();
  const std::size_t capacity = 2 * w + 1;
  out.assign(n, std::numeric_limits<double>::quiet_NaN());
  count.assign(n, 0);
  std::size_t next = 0;  // next index to enter the window
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t last = std::min(n - 1, i + w);
    if (i > w && next <= last) {
      // Index i - w - 1 leaves and i + w enters through the same slot.
      window.replace(next % capacity, in[next]);
      ++next;
    } else if (i > w) {
      window.erase((i - w - 1) % capacity);
    }
    for (; next <= last; ++next) {
      if (std::isfinite(in[next])) window.insert(next % capacity, in[next]);
    }
    out[i] = window.median();
    count[i] = window.size();
  }
  // Empty the window for the next use.
  for (std::size_t slot = 0; slot < capacity; ++slot) window.erase(slot);
}

/// |b[i-L] - 2 b[i] + b[i+L]| of the running median b, L = w (shorter near the ends), nT;
/// 0 where it is not finite. Bounds the median's own cut at the crest of a fast oscillation.
double curvature_allowance(const std::vector<double>& median, std::size_t i, std::size_t w) {
  const std::size_t lag = std::min({w, i, median.size() - 1 - i});
  if (lag == 0) return 0.0;
  const double d2 = std::abs(median[i - lag] - 2.0 * median[i] + median[i + lag]);
  return std::isfinite(d2) ? d2 : 0.0;
}

}  // namespace

void DespikeSettings::validate() const {
  if (half_window < 1) throw InputError("despike half_window", "must be at least 1 sample");
  if (!(threshold > 0.0) || !std::isfinite(threshold)) {
    throw InputError("despike threshold", "must be positive and finite");
  }
  if (!(min_threshold_nT >= 0.0) || !std::isfinite(min_threshold_nT)) {
    throw InputError("despike min_threshold_nT", "must be >= 0 and finite");
  }
}

std::size_t despike(Readings& values, const DespikeSettings& settings) {
  settings.validate();
  const std::size_t n = static_cast<std::size_t>(values.rows());
  const std::size_t w = settings.half_window;
  constexpr double kMadToSigma = 1.4826;
  SlidingMedian window(2 * w + 1);
  std::vector<double> x(n), median(n), residual(n), abs_residual(n), mad(n);
  std::vector<std::size_t> count(n), unused(n);
  std::size_t flagged = 0;
  for (Eigen::Index c = 0; c < values.cols(); ++c) {
    for (std::size_t i = 0; i < n; ++i) x[i] = values(static_cast<Eigen::Index>(i), c);
    running_median(x, w, median, count, window);
    for (std::size_t i = 0; i < n; ++i) {
      residual[i] = x[i] - median[i];  // NaN where x is NaN
      abs_residual[i] = std::abs(residual[i]);
    }
    running_median(abs_residual, w, mad, unused, window);
    for (std::size_t i = 0; i < n; ++i) {
      if (!std::isfinite(residual[i]) || count[i] < 3) continue;
      const double limit = std::max({settings.threshold * kMadToSigma * mad[i],
                                     settings.min_threshold_nT, curvature_allowance(median, i, w)});
      if (abs_residual[i] > limit) {
        values(static_cast<Eigen::Index>(i), c) = std::numeric_limits<double>::quiet_NaN();
        ++flagged;
      }
    }
  }
  return flagged;
}

}  // namespace magnetometer_insitu_calibration
