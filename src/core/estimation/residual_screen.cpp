// Residual screen of the robust estimator (robust_estimator.hpp, step 1): flags the samples
// where T - R n, high-passed by a running median, is an outlier.
#include "magnetometer_insitu_calibration/estimation/robust_estimator.hpp"

#include "bracketed_median.hpp"
#include "spectral_tools.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace magnetometer_insitu_calibration {

namespace {

/// Exact medians of x[0 .. n) over `window` values centred every `step` values (the last centre
/// at n - 1): centres (indices into x) and values. Each window's median is searched
/// (BracketedMedian) where the previous one's rank in the new window puts it, in a bracket sized
/// to hold a few dozen values; the result is exactly the window's median.
void running_medians(const double* x, std::size_t n, std::size_t window, std::size_t step, std::vector<double>& centres,
                     std::vector<double>& values) {
  centres.clear();
  values.clear();
  if (n == 0) return;
  window = std::min(window, n);
  detail::BracketedMedian selector;
  const double target = std::max(32.0, static_cast<double>(window) / 64.0);  // values in the bracket
  double density = 0.0;  // values of the last window per unit of x near its median
  for (std::size_t c = 0;; c += step) {
    const std::size_t centre_index = std::min(c, n - 1);
    const std::size_t first = centre_index >= window / 2 ? centre_index - window / 2 : 0;
    const std::size_t last = std::min(n, first + window);
    const std::size_t count = last - first;
    const double* data = x + first;
    double m;
    if (values.empty() || !(density > 0.0)) {
      m = detail::subsampled_median(data, count, selector);
    } else {
      // The last median's exact rank r in this window says how far the new median is in rank,
      // (k - r) values (k: the middle rank), about (k - r) / density in x: the bracket is
      // centred there and holds about `target` values more than that distance needs.
      const double previous = values.back();
      const double r = static_cast<double>(
          detail::BracketedMedian::count_outside(data, count, previous, std::numeric_limits<double>::infinity()).first);
      const double shift = (0.5 * static_cast<double>(count - 1) - r) / density;
      m = selector.median(data, count, previous + shift, 0.5 * target / density + 0.25 * std::abs(shift));
    }
    const double width = selector.last_half_width();
    if (width > 0.0 && selector.last_inside() > 1) {
      density = static_cast<double>(selector.last_inside()) / (2.0 * width);
    } else {
      const auto [lo, hi] = std::minmax_element(data, data + count);
      density = *hi > *lo ? static_cast<double>(count) / (*hi - *lo) : 0.0;
    }
    centres.push_back(static_cast<double>(centre_index));
    values.push_back(m);
    if (centre_index == n - 1) break;
  }
}

/// x minus its running-median baseline, into hp. The baseline is computed on a decimated
/// series: the means of blocks of `decimation` samples (the last block may be shorter), their
/// exact running median over window / decimation blocks every step / decimation blocks,
/// interpolated linearly between the blocks' centre times (flat beyond the first and last).
/// O(N) with a small constant: the medians see a tenth of the values (a spike enters one block
/// mean; the median of the blocks ignores it as the median of the samples did).
void subtract_running_median(const Eigen::VectorXd& x, std::size_t window, std::size_t step, std::size_t decimation,
                             Eigen::VectorXd& hp) {
  const std::size_t n = static_cast<std::size_t>(x.size());
  hp.resize(x.size());
  if (n == 0) return;
  decimation = std::max<std::size_t>(1, decimation);
  thread_local std::vector<double> blocks, centres, values;
  const std::size_t count = (n + decimation - 1) / decimation;
  blocks.resize(count);
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t first = k * decimation, last = std::min(n, first + decimation);
    double sum = 0.0;
    for (std::size_t i = first; i < last; ++i) sum += x(static_cast<Eigen::Index>(i));
    blocks[k] = sum / static_cast<double>(last - first);
  }
  running_medians(blocks.data(), count, std::max<std::size_t>(3, window / decimation),
                  std::max<std::size_t>(1, step / decimation), centres, values);
  for (double& c : centres) {  // block index -> sample time of the block's centre
    const std::size_t k = static_cast<std::size_t>(c);
    const std::size_t first = k * decimation, last = std::min(n, first + decimation);
    c = 0.5 * static_cast<double>(first + last - 1);
  }
  // Each segment's samples found first, so that the loops over them have no exit test (they
  // vectorise); int indices convert to double two at a time. The arithmetic is as before.
  const auto upto = [&](double centre) {  // first sample after `centre` (samples are integers)
    return static_cast<int>(std::min<double>(static_cast<double>(n), std::floor(centre) + 1.0));
  };
  const double* in = x.data();
  double* out = hp.data();
  int i = 0;
  const int head = upto(centres.front());
  const double first_value = values.front();
  for (; i < head; ++i) out[i] = in[i] - first_value;
  for (std::size_t k = 0; k + 1 < centres.size(); ++k) {  // samples in (centres[k], centres[k + 1]]
    const double slope = (values[k + 1] - values[k]) / (centres[k + 1] - centres[k]);
    const double value = values[k], centre = centres[k];
    const int end = upto(centres[k + 1]);
    for (; i < end; ++i) out[i] = in[i] - (value + (static_cast<double>(i) - centre) * slope);
  }
  const double last_value = values.back();
  for (; i < static_cast<int>(n); ++i) out[i] = in[i] - last_value;
}

/// Work arrays of one screen (N values each), kept per thread so that a run of windows of
/// one length allocates (and page-faults) once.
struct ScreenScratch {
  Eigen::VectorXd e, hp;
  std::vector<double> sample;
};

/// Values of the residual the screen's centre and MAD are taken from (every stride-th).
constexpr std::size_t kScreenMedianSample = 8192;

}  // namespace

std::vector<char> screen_residual(const Eigen::Ref<const Readings>& reference_nT, const Eigen::Ref<const Readings>& test_nT,
                                  const Eigen::Matrix3d& n, double sample_period_s, const RobustSettings& settings) {
  const std::size_t length = static_cast<std::size_t>(reference_nT.rows());
  std::vector<char> mask(length, 0);
  if (length < 16 || !n.allFinite()) return mask;
  thread_local ScreenScratch scratch;
  const std::size_t window = std::max<std::size_t>(3, static_cast<std::size_t>(std::llround(settings.screen_baseline_s / sample_period_s)));
  const std::size_t step = std::max<std::size_t>(1, window / 10);
  const std::size_t decimation = std::max<std::size_t>(1, step / 36);  // 10 at 1 Hz (360 blocks a window)
  const std::size_t margin = static_cast<std::size_t>(std::llround(settings.screen_margin_s / sample_period_s));
  std::vector<char> flag(length, 0);
  bool any = false;
  for (int c = 0; c < 3; ++c) {
    Eigen::VectorXd& e = scratch.e;
    Eigen::VectorXd& hp = scratch.hp;
    e.noalias() = test_nT.col(c) - reference_nT * n.col(c);  // residual T - R n, nT
    subtract_running_median(e, window, step, decimation, hp);
    // The centre and the MAD from every stride-th value (about 8200 of them): the threshold is
    // then within about 1.3 % of the exact medians'; one pass flags.
    const std::size_t stride = std::max<std::size_t>(1, length / kScreenMedianSample);
    std::vector<double>& sample = scratch.sample;
    sample.clear();
    for (std::size_t i = 0; i < length; i += stride) sample.push_back(hp(static_cast<Eigen::Index>(i)));
    const double centre = detail::median(sample);
    for (double& v : sample) v = std::abs(v - centre);
    const double sigma = 1.4826 * detail::median(sample);
    if (!(sigma > 0.0)) continue;
    const double limit = settings.screen_threshold * sigma;
    const double* h = hp.data();
    bool column_flags = false;
    for (std::size_t i = 0; i < length; ++i) {
      const bool out = std::abs(h[i] - centre) > limit;
      flag[i] |= out;
      column_flags |= out;
    }
    any |= column_flags;
  }
  if (!any) return mask;
  // Widen each flagged sample by the margin (a transient's tails are below the threshold).
  long last_flag = -1;
  for (std::size_t i = 0; i < length; ++i) {
    if (flag[i]) last_flag = static_cast<long>(i);
    if (last_flag >= 0 && static_cast<long>(i) - last_flag <= static_cast<long>(margin)) mask[i] = 1;
  }
  last_flag = -1;
  for (std::size_t i = length; i-- > 0;) {
    if (flag[i]) last_flag = static_cast<long>(i);
    if (last_flag >= 0 && last_flag - static_cast<long>(i) <= static_cast<long>(margin)) mask[i] = 1;
  }
  return mask;
}

}  // namespace magnetometer_insitu_calibration
