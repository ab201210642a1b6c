// Residual screen of the robust estimator (robust_estimator.hpp, step 1): flags the samples
// where T - R n, high-passed by a running median, is an outlier.
#include "magnetometer_insitu_calibration/estimation/robust/residual_screen.hpp"

#include "bracketed_median.hpp"
#include "../spectral_tools.hpp"

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

/// A residual's running-median baseline: the exact running median of its block means (blocks
/// of `decimation` samples, the last may be shorter) over window / decimation blocks every
/// step / decimation blocks, interpolated linearly between the blocks' centre times (flat beyond
/// the first and last). O(N) with a small constant: the medians see a tenth of the values (a
/// spike enters one block mean; the median of the blocks ignores it as the median of the
/// samples did).
struct Baseline {
  std::vector<double> centres, values;  ///< sample index of each median's block centre; nT

  void fit(const std::vector<double>& block_means, std::size_t n, std::size_t window, std::size_t step,
           std::size_t decimation) {
    running_medians(block_means.data(), block_means.size(), std::max<std::size_t>(3, window / decimation),
                    std::max<std::size_t>(1, step / decimation), centres, values);
    for (double& c : centres) {  // block index -> sample time of the block's centre
      const std::size_t k = static_cast<std::size_t>(c);
      const std::size_t first = k * decimation, last = std::min(n, first + decimation);
      c = 0.5 * static_cast<double>(first + last - 1);
    }
  }
};

/// The three residuals' baselines as one piecewise-linear schedule (their blocks and centres
/// are the same): the samples [begin, end) of a piece (before the first centre, between two
/// centres, after the last) and each residual's baseline there, value + (i - centre) * slope.
struct BaselinePieces {
  struct Piece {
    int begin = 0, end = 0;
    double centre = 0.0;  ///< sample index
    double value[3] = {0, 0, 0}, slope[3] = {0, 0, 0};
  };
  std::vector<Piece> pieces;

  void build(const Baseline (&b)[3], std::size_t n) {
    const auto upto = [&](double centre) {  // first sample after `centre` (samples are integers)
      return static_cast<int>(std::min<double>(static_cast<double>(n), std::floor(centre) + 1.0));
    };
    const std::vector<double>& centres = b[0].centres;  // the same blocks for every residual
    pieces.clear();
    Piece head;
    head.end = upto(centres.front());
    for (int c = 0; c < 3; ++c) head.value[c] = b[c].values.front();
    pieces.push_back(head);
    for (std::size_t k = 0; k + 1 < centres.size(); ++k) {  // samples in (centres[k], centres[k + 1]]
      Piece p;
      p.begin = pieces.back().end;
      p.end = upto(centres[k + 1]);
      p.centre = centres[k];
      for (int c = 0; c < 3; ++c) {
        p.value[c] = b[c].values[k];
        p.slope[c] = (b[c].values[k + 1] - b[c].values[k]) / (centres[k + 1] - centres[k]);
      }
      pieces.push_back(p);
    }
    Piece tail;
    tail.begin = pieces.back().end;
    tail.end = static_cast<int>(n);
    for (int c = 0; c < 3; ++c) tail.value[c] = b[c].values.back();
    pieces.push_back(tail);
  }
};

/// Work arrays of one screen, kept per thread so that a run of windows of one length allocates
/// (and page-faults) once.
struct ScreenScratch {
  std::vector<double> blocks[3];  ///< each residual's block means, nT
  std::vector<double> sample;
  std::vector<char> flag;
  Baseline baseline[3];
  BaselinePieces pieces;
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
  // The residuals e_c = T_c - R n_c, nT, are never stored: one pass sums them in blocks, a
  // second flags them against their baselines (the records are read twice, not nine times).
  const double* r[3] = {reference_nT.col(0).data(), reference_nT.col(1).data(), reference_nT.col(2).data()};
  const double* t[3] = {test_nT.col(0).data(), test_nT.col(1).data(), test_nT.col(2).data()};
  const auto residual = [&](std::size_t i, int c) {
    return t[c][i] - (r[0][i] * n(0, c) + r[1][i] * n(1, c) + r[2][i] * n(2, c));
  };
  const std::size_t count = (length + decimation - 1) / decimation;
  for (int c = 0; c < 3; ++c) scratch.blocks[c].resize(count);
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t first = k * decimation, last = std::min(length, first + decimation);
    double sum[3] = {0.0, 0.0, 0.0};
    for (std::size_t i = first; i < last; ++i) {
      for (int c = 0; c < 3; ++c) sum[c] += residual(i, c);
    }
    for (int c = 0; c < 3; ++c) scratch.blocks[c][k] = sum[c] / static_cast<double>(last - first);
  }
  for (int c = 0; c < 3; ++c) scratch.baseline[c].fit(scratch.blocks[c], length, window, step, decimation);
  BaselinePieces& pieces = scratch.pieces;
  pieces.build(scratch.baseline, length);
  // Each residual's centre and MAD, less its baseline, from every stride-th value (about 8200
  // of them): the threshold is then within about 1.3 % of the exact medians'.
  const std::size_t stride = std::max<std::size_t>(1, length / kScreenMedianSample);
  double centre[3], limit[3];  // nT; a residual whose MAD is zero flags nothing: its limit is infinite
  for (int c = 0; c < 3; ++c) {
    std::vector<double>& sample = scratch.sample;
    sample.clear();
    for (const BaselinePieces::Piece& p : pieces.pieces) {
      std::size_t i = (static_cast<std::size_t>(p.begin) + stride - 1) / stride * stride;
      for (; i < static_cast<std::size_t>(p.end); i += stride) {
        sample.push_back(residual(i, c) - (p.value[c] + (static_cast<double>(i) - p.centre) * p.slope[c]));
      }
    }
    centre[c] = detail::median(sample);
    for (double& v : sample) v = std::abs(v - centre[c]);
    const double sigma = 1.4826 * detail::median(sample);
    limit[c] = sigma > 0.0 ? settings.screen_threshold * sigma : std::numeric_limits<double>::infinity();
  }
  // The flag pass, in locals: the char stores would otherwise make the compiler reload n and
  // the piece's values at every sample.
  const double n00 = n(0, 0), n10 = n(1, 0), n20 = n(2, 0), n01 = n(0, 1), n11 = n(1, 1), n21 = n(2, 1),
               n02 = n(0, 2), n12 = n(1, 2), n22 = n(2, 2);
  const double *r0 = r[0], *r1 = r[1], *r2 = r[2], *t0 = t[0], *t1 = t[1], *t2 = t[2];
  std::vector<char>& flag = scratch.flag;
  flag.assign(length, 0);
  char* f = flag.data();
  char any = 0;
  for (const BaselinePieces::Piece& p : pieces.pieces) {
    const double v0 = p.value[0], v1 = p.value[1], v2 = p.value[2];
    const double s0 = p.slope[0], s1 = p.slope[1], s2 = p.slope[2], x0 = p.centre;
    const double c0 = centre[0], c1 = centre[1], c2 = centre[2], l0 = limit[0], l1 = limit[1], l2 = limit[2];
    const int begin = p.begin, end = p.end;
    char piece_any = 0;
    for (int i = begin; i < end; ++i) {
      const double d = static_cast<double>(i) - x0;
      const double h0 = t0[i] - (r0[i] * n00 + r1[i] * n10 + r2[i] * n20) - (v0 + d * s0);
      const double h1 = t1[i] - (r0[i] * n01 + r1[i] * n11 + r2[i] * n21) - (v1 + d * s1);
      const double h2 = t2[i] - (r0[i] * n02 + r1[i] * n12 + r2[i] * n22) - (v2 + d * s2);
      const char out = static_cast<char>((std::abs(h0 - c0) > l0) | (std::abs(h1 - c1) > l1) | (std::abs(h2 - c2) > l2));
      f[i] = out;
      piece_any |= out;
    }
    any |= piece_any;
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
