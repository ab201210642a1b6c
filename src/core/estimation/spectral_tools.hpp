// Internal helpers of the robust estimator, the band selection and the delay estimation:
// real DFTs of any length (FFTW, plans cached per length), detrending, medians, masking.
// Not installed: src/core only.
#pragma once

#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <Eigen/Core>
#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstddef>
#include <map>
#include <mutex>
#include <vector>

namespace magnetometer_insitu_calibration::detail {

/// Unnormalised forward real DFT X_j = sum_t x_t e^{-2 pi i j t / L}, j = 0 .. L/2 (FFTW's
/// convention). One plan per length, kept for the life of the object; one object per thread.
class RealDft {
 public:
  RealDft() = default;
  RealDft(const RealDft&) = delete;
  RealDft& operator=(const RealDft&) = delete;
  ~RealDft() { release(); }

  /// Transforms x (length L) into out (L/2 + 1 bins).
  void transform(const double* x, std::size_t length, Eigen::VectorXcd& out) { transform(x, length, length, out); }

  /// Transforms x[0 .. count) followed by length - count zeros (count <= length) into out
  /// (length/2 + 1 bins, harmonic j at j / (length dt)).
  void transform(const double* x, std::size_t count, std::size_t length, Eigen::VectorXcd& out) {
    Plan& p = plan(length);
    std::copy(x, x + count, p.in);
    std::fill(p.in + count, p.in + length, 0.0);
    fftw_execute(p.plan);
    out.resize(static_cast<Eigen::Index>(length / 2 + 1));
    for (std::size_t j = 0; j < length / 2 + 1; ++j) out(static_cast<Eigen::Index>(j)) = {p.out[j][0], p.out[j][1]};
  }

  /// The input array of the plan for `length` (values): fill it, then execute(length, ...).
  double* input(std::size_t length) { return plan(length).in; }

  /// Transforms what input(length) holds into out: bins 0 .. bins - 1 (bins <= length/2 + 1).
  void execute(std::size_t length, std::size_t bins, Eigen::VectorXcd& out) {
    Plan& p = plan(length);
    fftw_execute(p.plan);
    bins = std::min(bins, length / 2 + 1);
    out.resize(static_cast<Eigen::Index>(bins));
    for (std::size_t j = 0; j < bins; ++j) out(static_cast<Eigen::Index>(j)) = {p.out[j][0], p.out[j][1]};
  }

 private:
  struct Plan {
    double* in = nullptr;
    fftw_complex* out = nullptr;
    fftw_plan plan = nullptr;
  };
  Plan& plan(std::size_t length) {
    auto it = plans_.find(length);
    if (it != plans_.end()) return it->second;
    if (plans_.size() >= kMaxPlans) release();  // lengths change: keep memory O(N)
    Plan p;
    p.in = fftw_alloc_real(length);
    p.out = fftw_alloc_complex(length / 2 + 1);
    if (p.in == nullptr || p.out == nullptr) throw std::bad_alloc();
    {
      std::lock_guard<std::mutex> lock(fftw_planner_lock());
      p.plan = fftw_plan_dft_r2c_1d(static_cast<int>(length), p.in, p.out, FFTW_ESTIMATE);
    }
    if (p.plan == nullptr) throw std::runtime_error("FFTW could not plan a transform");
    return plans_.emplace(length, p).first->second;
  }
  void release() {
    std::lock_guard<std::mutex> lock(fftw_planner_lock());
    for (auto& [length, plan] : plans_) {
      fftw_destroy_plan(plan.plan);
      fftw_free(plan.in);
      fftw_free(plan.out);
    }
    plans_.clear();
  }
  static constexpr std::size_t kMaxPlans = 8;  ///< lengths kept (a window uses 1-4)
  std::map<std::size_t, Plan> plans_;
};

/// This thread's RealDft, for the free functions (band selection, delay, relative response) that
/// transform whole windows: planning and allocating a 1-day transform costs about as much as
/// executing it, so the plans are kept between calls (at most RealDft::kMaxPlans lengths).
inline RealDft& thread_real_dft() {
  thread_local RealDft dft;
  return dft;
}

/// Removes the least-squares line a + b t from x in place. A linear operator applied alike to
/// every column of R and T keeps T = R n + d exactly (it only changes d), so detrending both
/// instruments is not an approximation.
inline void detrend(double* x, std::size_t length) {
  if (length < 2) {
    if (length == 1) x[0] = 0.0;
    return;
  }
  const double centre = 0.5 * static_cast<double>(length - 1);
  double mean = 0.0, slope_num = 0.0, slope_den = 0.0;
  for (std::size_t i = 0; i < length; ++i) mean += x[i];
  mean /= static_cast<double>(length);
  for (std::size_t i = 0; i < length; ++i) {
    const double t = static_cast<double>(i) - centre;
    slope_num += t * (x[i] - mean);
    slope_den += t * t;
  }
  const double slope = slope_num / slope_den;
  for (std::size_t i = 0; i < length; ++i) x[i] -= mean + slope * (static_cast<double>(i) - centre);
}

/// The least-squares lines a + b (i - centre) of K columns of one length at once, with exactly
/// detrend()'s arithmetic (the same sums in the same order, so the same doubles): the K running
/// sums are independent, so their additions overlap instead of waiting for each other.
template <int K>
void fit_lines(const double* const* x, std::size_t length, double* mean, double* slope) {
  const double centre = 0.5 * static_cast<double>(length - 1);
  double slope_num[K];
  for (int c = 0; c < K; ++c) mean[c] = slope_num[c] = 0.0;
  double slope_den = 0.0;
  for (std::size_t i = 0; i < length; ++i)
    for (int c = 0; c < K; ++c) mean[c] += x[c][i];
  for (int c = 0; c < K; ++c) mean[c] /= static_cast<double>(length);
  for (std::size_t i = 0; i < length; ++i) {
    const double t = static_cast<double>(i) - centre;
    for (int c = 0; c < K; ++c) slope_num[c] += t * (x[c][i] - mean[c]);
    slope_den += t * t;
  }
  for (int c = 0; c < K; ++c) slope[c] = slope_num[c] / slope_den;
}

/// out[i] = x[i] minus the line of fit_lines (out may be x), as detrend() subtracts it.
inline void subtract_line(const double* x, std::size_t length, double mean, double slope, double* out) {
  const double centre = 0.5 * static_cast<double>(length - 1);
  for (std::size_t i = 0; i < length; ++i) out[i] = x[i] - (mean + slope * (static_cast<double>(i) - centre));
}

/// detrend() of K columns of one length at once (fit_lines, then subtract_line in place).
template <int K>
void detrend_columns(double* const* x, std::size_t length) {
  if (length < 2) {
    for (int c = 0; c < K; ++c) detrend(x[c], length);
    return;
  }
  double mean[K], slope[K];
  fit_lines<K>(x, length, mean, slope);
  for (int c = 0; c < K; ++c) subtract_line(x[c], length, mean[c], slope[c], x[c]);
}

/// Median of v, reordering it (empty: NaN).
inline double median_in_place(std::vector<double>& v) {
  if (v.empty()) return std::nan("");
  const std::size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  double m = v[mid];
  if (v.size() % 2 == 0) {
    m = 0.5 * (m + *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid)));
  }
  return m;
}

/// Median of a copy (empty: NaN).
inline double median(std::vector<double> v) { return median_in_place(v); }

/// Replaces every run of masked samples, in every column of both R and T, by the straight line
/// between the means of the unmasked samples on either side, each taken over as many samples as
/// the run is long (fewer where the next run or the record's end comes first) and placed at their
/// mean epoch; flat at the record's ends. The same weights at the same epochs in both instruments
/// keep T = R n + d (as regularize_and_fill does for gaps), and a linear signal is reproduced
/// exactly. Why means, not the two neighbours: a line through two noisy samples puts their noise
/// into the band as a slow ramp (a 61 s run: about 30x the in-band PSD of white noise over its
/// span), an error in the regressor that attenuates n. With the reference's white noise 0.1 nT
/// and 20 masked spikes (2.8 % of a 12 h window) the neighbours' lines moved n by 1.3 standard
/// errors; means over the run's length put back about the noise the run held.
inline void fill_masked(Readings& reference, Readings& test, const std::vector<char>& mask) {
  const std::size_t n = mask.size();
  std::size_t i = 0;
  while (i < n) {
    if (!mask[i]) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j < n && mask[j]) ++j;  // run [i, j)
    const std::size_t length = j - i;
    // Unmasked samples on each side, up to `length` of them: [left_first, i) and [j, right_end).
    std::size_t left_first = i;
    while (left_first > 0 && i - left_first < length && !mask[left_first - 1]) --left_first;
    std::size_t right_end = j;
    while (right_end < n && right_end - j < length && !mask[right_end]) ++right_end;
    const bool has_left = left_first < i, has_right = right_end > j;
    const double left_t = 0.5 * (static_cast<double>(left_first) + static_cast<double>(i - 1));
    const double right_t = 0.5 * (static_cast<double>(j) + static_cast<double>(right_end - 1));
    for (Readings* r : {&reference, &test}) {
      for (int c = 0; c < 3; ++c) {
        double left = std::nan(""), right = std::nan("");
        if (has_left) {
          left = 0.0;
          for (std::size_t k = left_first; k < i; ++k) left += (*r)(static_cast<Eigen::Index>(k), c);
          left /= static_cast<double>(i - left_first);
        }
        if (has_right) {
          right = 0.0;
          for (std::size_t k = j; k < right_end; ++k) right += (*r)(static_cast<Eigen::Index>(k), c);
          right /= static_cast<double>(right_end - j);
        }
        for (std::size_t k = i; k < j; ++k) {
          double v;
          if (has_left && has_right) {
            const double a = (static_cast<double>(k) - left_t) / (right_t - left_t);
            v = left + a * (right - left);
          } else {
            v = has_left ? left : right;
          }
          (*r)(static_cast<Eigen::Index>(k), c) = v;
        }
      }
    }
    i = j;
  }
}

}  // namespace magnetometer_insitu_calibration::detail
