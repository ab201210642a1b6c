// Windowed-sinc interpolation of a regular record: see band_limited_interpolation.hpp.
#include "magnetometer_insitu_calibration/preprocessing/band_limited_interpolation.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <stdexcept>

namespace magnetometer_insitu_calibration {

namespace {

double sinc(double x) { return x == 0.0 ? 1.0 : std::sin(M_PI * x) / (M_PI * x); }

void check(double period_s, int half_width) {
  if (!(period_s > 0.0) || !std::isfinite(period_s)) throw std::invalid_argument("interpolation: period must be > 0 s");
  if (half_width < 1) throw std::invalid_argument("interpolation: half_width must be >= 1");
}

/// Row i (the sample at or before t) and the fraction u of the step after it; false outside.
bool locate(double t, double t0_s, double period_s, Eigen::Index rows, Eigen::Index& i, double& u) {
  const double x = (t - t0_s) / period_s;
  if (!(x >= 0.0) || x > static_cast<double>(rows - 1)) return false;
  i = std::min(static_cast<Eigen::Index>(std::floor(x)), rows - 1);
  u = x - static_cast<double>(i);
  return true;
}

}  // namespace

std::vector<double> lanczos_weights(double u, int half_width) {
  check(1.0, half_width);
  std::vector<double> w(2 * static_cast<std::size_t>(half_width), 0.0);
  if (u == 0.0) {
    w[static_cast<std::size_t>(half_width) - 1] = 1.0;  // sample i itself
    return w;
  }
  const double a = static_cast<double>(half_width);
  double sum = 0.0;
  for (int k = -half_width + 1; k <= half_width; ++k) {
    const double d = u - static_cast<double>(k);
    const double value = sinc(d) * sinc(d / a);
    w[static_cast<std::size_t>(k + half_width - 1)] = value;
    sum += value;
  }
  for (double& v : w) v /= sum;
  return w;
}

Readings interpolate_regular(const Readings& values, double t0_s, double period_s, const std::vector<double>& at,
                             int half_width) {
  check(period_s, half_width);
  Readings out = Readings::Constant(static_cast<Eigen::Index>(at.size()), values.cols(),
                                    std::numeric_limits<double>::quiet_NaN());
  const Eigen::Index rows = values.rows();
  if (rows == 0) return out;
  for (std::size_t p = 0; p < at.size(); ++p) {
    Eigen::Index i = 0;
    double u = 0.0;
    if (!locate(at[p], t0_s, period_s, rows, i, u)) continue;
    const std::vector<double> w = lanczos_weights(u, half_width);
    Eigen::RowVectorXd sum = Eigen::RowVectorXd::Zero(values.cols());
    for (int k = -half_width + 1; k <= half_width; ++k) {
      const double weight = w[static_cast<std::size_t>(k + half_width - 1)];
      if (weight == 0.0) continue;
      sum += weight * values.row(std::clamp<Eigen::Index>(i + k, 0, rows - 1));
    }
    out.row(static_cast<Eigen::Index>(p)) = sum;  // NaN when a weighted row was missing
  }
  return out;
}

InterpolatedNoise interpolated_noise(double t0_s, double period_s, const std::vector<double>& at,
                                     double resample_period_s, int half_width) {
  check(period_s, half_width);
  InterpolatedNoise out;
  if (at.empty()) return out;
  // Folded frequencies m / resample_period_s below the grid's Nyquist frequency.
  const int folds = static_cast<int>(std::ceil(0.5 / period_s * resample_period_s)) - 1;
  std::vector<double> response2(static_cast<std::size_t>(std::max(0, folds)), 0.0);
  double white = 0.0;
  const std::size_t stride = std::max<std::size_t>(1, at.size() / 256);  // the fractions repeat
  std::size_t points = 0;
  for (std::size_t p = 0; p < at.size(); p += stride, ++points) {
    const double x = (at[p] - t0_s) / period_s;
    const double u = x - std::floor(x);
    const std::vector<double> w = lanczos_weights(u, half_width);
    for (const double v : w) white += v * v;
    for (int m = 1; m <= folds; ++m) {
      std::complex<double> h = 0.0;
      const double f = static_cast<double>(m) / resample_period_s;  // Hz
      for (int k = -half_width + 1; k <= half_width; ++k) {
        h += w[static_cast<std::size_t>(k + half_width - 1)] *
             std::polar(1.0, -2.0 * M_PI * f * (static_cast<double>(k) - u) * period_s);
      }
      response2[static_cast<std::size_t>(m - 1)] += std::norm(h);
    }
  }
  out.white_variance = white / static_cast<double>(points);
  for (int m = 1; m <= folds; ++m) {
    out.pink_alias += response2[static_cast<std::size_t>(m - 1)] / static_cast<double>(points) / static_cast<double>(m);
  }
  return out;
}

}  // namespace magnetometer_insitu_calibration
