// Exact medians for the residual screen without a full selection per window: the order
// statistics are looked for between two values a <= b that probably bracket them (the previous
// window's median, a subsample's quantiles); one pass counts the values below a and copies those
// in [a, b]; when the counts prove that the wanted order statistics lie in [a, b] they are
// selected among the copied few, otherwise the bracket is widened and, at last, the whole
// window is selected. The result is the same value detail::median returns (same order
// statistics, same arithmetic), only found with less work. Not installed: src/core only.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace magnetometer_insitu_calibration::detail {

class BracketedMedian {
 public:
  /// Median of x[0 .. n) (n >= 1, finite values), as detail::median: the middle order statistic,
  /// or for even n the mean of the two middle ones. `centre` and `half_width` (units of x) are
  /// the guess; a NaN centre or a half width <= 0 goes straight to the full selection.
  double median(const double* x, std::size_t n, double centre, double half_width) {
    const std::size_t k_hi = n / 2, k_lo = n % 2 == 0 ? k_hi - 1 : k_hi;
    if (std::isfinite(centre) && half_width > 0.0 && std::isfinite(half_width)) {
      double a = centre - half_width, b = centre + half_width;
      for (int attempt = 0; attempt < 4; ++attempt) {
        const auto [below, above] = count_outside(x, n, a, b);  // counting first: no stores
        const std::size_t count = n - below - above;
        if (below <= k_lo && below + count > k_hi) {
          copy_inside(x, n, a, b, count);
          last_inside_ = count;
          last_half_width_ = 0.5 * (b - a);
          return from_inside(count, k_hi - below, k_lo - below, n % 2 == 0);
        }
        // Widen on the side where the counts put the missing order statistics.
        const double step = 4.0 * (b - a);
        if (below > k_lo) a -= step;
        if (below + count <= k_hi) b += step;
      }
    }
    last_inside_ = n;
    last_half_width_ = std::nan("");
    inside_.assign(x, x + n);
    return from_inside(n, k_hi, k_lo, n % 2 == 0);
  }

  /// Values of x[0 .. n) below a and above b (two per SSE2 instruction where there is SSE2).
  static std::pair<std::size_t, std::size_t> count_outside(const double* x, std::size_t n, double a, double b) {
    std::size_t below = 0, above = 0, i = 0;
#if defined(__SSE2__)
    const __m128d va = _mm_set1_pd(a), vb = _mm_set1_pd(b);
    __m128i vbelow = _mm_setzero_si128(), vabove = _mm_setzero_si128();
    for (; i + 2 <= n; i += 2) {  // a true compare is all ones, -1 as an integer
      const __m128d v = _mm_loadu_pd(x + i);
      vbelow = _mm_sub_epi64(vbelow, _mm_castpd_si128(_mm_cmplt_pd(v, va)));
      vabove = _mm_sub_epi64(vabove, _mm_castpd_si128(_mm_cmpgt_pd(v, vb)));
    }
    alignas(16) std::int64_t lanes[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(lanes), vbelow);
    _mm_store_si128(reinterpret_cast<__m128i*>(lanes + 2), vabove);
    below = static_cast<std::size_t>(lanes[0] + lanes[1]);
    above = static_cast<std::size_t>(lanes[2] + lanes[3]);
#endif
    for (; i < n; ++i) {
      below += x[i] < a;
      above += x[i] > b;
    }
    return {below, above};
  }

  /// Copies the `count` values of x[0 .. n) in [a, b] to inside_, in order.
  void copy_inside(const double* x, std::size_t n, double a, double b, std::size_t count) {
    inside_.resize(count + 2);
    double* out = inside_.data();
    std::size_t kept = 0, i = 0;
#if defined(__SSE2__)
    const __m128d va = _mm_set1_pd(a), vb = _mm_set1_pd(b);
    for (; i + 2 <= n && kept + 2 <= count; i += 2) {  // most pairs hold no value inside: skipped
      const __m128d v = _mm_loadu_pd(x + i);
      const int in = _mm_movemask_pd(_mm_and_pd(_mm_cmpge_pd(v, va), _mm_cmple_pd(v, vb)));
      if (in == 0) continue;
      out[kept] = x[i];
      kept += static_cast<std::size_t>(in & 1);
      out[kept] = x[i + 1];
      kept += static_cast<std::size_t>(in >> 1);
    }
#endif
    for (; i < n && kept < count; ++i) {  // always write, advance when inside
      out[kept] = x[i];
      kept += (x[i] >= a) & (x[i] <= b);
    }
  }

  /// Values copied into the last selection (n when it fell back to the whole window).
  std::size_t last_inside() const { return last_inside_; }
  /// Half width of the bracket that held them (NaN when it fell back to the whole window).
  double last_half_width() const { return last_half_width_; }

 private:
  /// Order statistics k_hi (and k_lo = k_hi - 1 for even n) of inside_[0 .. count).
  double from_inside(std::size_t count, std::size_t k_hi, std::size_t k_lo, bool even) {
    auto first = inside_.begin(), last = inside_.begin() + static_cast<std::ptrdiff_t>(count);
    auto hi = first + static_cast<std::ptrdiff_t>(k_hi);
    std::nth_element(first, hi, last);
    double m = *hi;
    if (even) m = 0.5 * (m + *std::max_element(first, first + static_cast<std::ptrdiff_t>(k_lo) + 1));
    return m;
  }

  std::vector<double> inside_;
  std::size_t last_inside_ = 0;
  double last_half_width_ = std::nan("");
};

/// Median of x[0 .. n) (n >= 1, finite) with the bracket taken from a subsample of about 4096
/// values: its order statistics 3 standard deviations of rank either side of its middle.
inline double subsampled_median(const double* x, std::size_t n, BracketedMedian& selector) {
  const std::size_t stride = std::max<std::size_t>(1, n / 4096);
  std::vector<double> sample;
  for (std::size_t i = 0; i < n; i += stride) sample.push_back(x[i]);
  if (sample.size() < 64) return selector.median(x, n, std::nan(""), 0.0);
  const std::size_t m = sample.size();
  const std::size_t margin = static_cast<std::size_t>(3.0 * 0.5 * std::sqrt(static_cast<double>(m))) + 2;
  const std::size_t lo = m / 2 > margin ? m / 2 - margin : 0, hi = std::min(m - 1, m / 2 + margin);
  std::nth_element(sample.begin(), sample.begin() + static_cast<std::ptrdiff_t>(lo), sample.end());
  const double a = sample[lo];
  std::nth_element(sample.begin() + static_cast<std::ptrdiff_t>(lo), sample.begin() + static_cast<std::ptrdiff_t>(hi),
                   sample.end());
  const double b = sample[hi];
  return selector.median(x, n, 0.5 * (a + b), 0.5 * (b - a));
}

}  // namespace magnetometer_insitu_calibration::detail
