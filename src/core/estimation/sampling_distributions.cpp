// Sampling distributions of the change and agreement tests: see sampling_distributions.hpp.
#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <utility>

namespace magnetometer_insitu_calibration {

double chi2_tail_probability(double x, double dof) {
  if (!(x > 0.0)) return 1.0;
  const double a = 0.5 * dof, z = 0.5 * x;
  const double log_prefactor = a * std::log(z) - z - std::lgamma(a);
  if (z < a + 1.0) {  // series for P(a, z), then Q = 1 - P
    double term = 1.0 / a, sum = term;
    for (int k = 1; k < 500; ++k) {
      term *= z / (a + k);
      sum += term;
      if (term < sum * 1e-15) break;
    }
    return std::max(0.0, 1.0 - sum * std::exp(log_prefactor));
  }
  // Continued fraction for Q(a, z) (modified Lentz).
  double b = z + 1.0 - a, c = 1.0 / 1e-300, d = 1.0 / b, h = d;
  for (int i = 1; i < 500; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < 1e-300) d = 1e-300;
    c = b + an / c;
    if (std::abs(c) < 1e-300) c = 1e-300;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < 1e-15) break;
  }
  return std::exp(log_prefactor) * h;
}

namespace {

/// Continued fraction of the regularised incomplete beta function (modified Lentz): I_x(a, b) =
/// x^a (1 - x)^b / (a B(a, b)) / (1 + d1 / (1 + d2 / (1 + ...))), d_2m+1 = -(a + m)(a + b + m) x /
/// ((a + 2m)(a + 2m + 1)), d_2m = m (b - m) x / ((a + 2m - 1)(a + 2m)); converges fast for
/// x < (a + 1) / (a + b + 2).
double beta_continued_fraction(double a, double b, double x) {
  constexpr double kTiny = 1e-300;
  double c = 1.0, d = 1.0 - (a + b) * x / (a + 1.0);
  if (std::abs(d) < kTiny) d = kTiny;
  d = 1.0 / d;
  double h = d;
  for (int m = 1; m < 1000; ++m) {
    const double even = m * (b - m) * x / ((a + 2.0 * m - 1.0) * (a + 2.0 * m));
    const double odd = -(a + m) * (a + b + m) * x / ((a + 2.0 * m) * (a + 2.0 * m + 1.0));
    for (double step : {even, odd}) {
      d = 1.0 + step * d;
      if (std::abs(d) < kTiny) d = kTiny;
      c = 1.0 + step / c;
      if (std::abs(c) < kTiny) c = kTiny;
      d = 1.0 / d;
      h *= d * c;
    }
    if (std::abs(d * c - 1.0) < 1e-15) break;
  }
  return h;
}

/// Regularised incomplete beta function I_x(a, b), a, b > 0.
double incomplete_beta(double x, double a, double b) {
  if (!(x > 0.0)) return 0.0;
  if (!(x < 1.0)) return 1.0;
  const double log_front = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
  if (x < (a + 1.0) / (a + b + 2.0)) return std::exp(log_front) * beta_continued_fraction(a, b, x) / a;
  return 1.0 - std::exp(log_front) * beta_continued_fraction(b, a, 1.0 - x) / b;
}

}  // namespace

double f_tail_probability(double f, double d1, double d2) {
  if (!(f > 0.0)) return 1.0;
  return incomplete_beta(d2 / (d2 + d1 * f), 0.5 * d2, 0.5 * d1);
}

namespace {

/// The quantile by bisection on the exact tail (see student_t_two_sided_quantile).
double student_t_quantile_by_bisection(double tail, double nu) {
  // P(|t_nu| > x) = P(F(1, nu) > x^2); for an infinite nu the normal's tail, erfc(x / sqrt 2).
  const auto tail_at = [&](double x) {
    return std::isfinite(nu) ? f_tail_probability(x * x, 1.0, nu) : std::erfc(x / std::sqrt(2.0));
  };
  // The tail falls with x; bracket the root, then bisect (the tail is continuous and monotone).
  double low = 0.0, high = 2.0;
  while (tail_at(high) > tail && high < 1e12) high *= 2.0;
  for (int i = 0; i < 200 && high - low > 1e-13 * high; ++i) {
    const double mid = 0.5 * (low + high);
    (tail_at(mid) > tail ? low : high) = mid;
  }
  return 0.5 * (low + high);
}

}  // namespace

double student_t_two_sided_quantile(double tail, double nu) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  if (!(nu > 0.0) || !(tail > 0.0) || !(tail < 1.0)) return kNaN;
  // Each bisection costs some 45 incomplete beta functions, slow to converge at many degrees of
  // freedom; a window asks for the same few (tail, nu) many times (each band and component of
  // its relative response): remembered per thread, the same value every time.
  thread_local std::map<std::pair<double, double>, double> known;
  const auto key = std::make_pair(tail, nu);
  const auto found = known.find(key);
  if (found != known.end()) return found->second;
  if (known.size() > 4096) known.clear();
  const double q = student_t_quantile_by_bisection(tail, nu);
  known.emplace(key, q);
  return q;
}

QuadraticFormMoments quadratic_form_moments(double nu, int p) {
  if (!std::isfinite(nu)) return {static_cast<double>(p), 2.0 * p};
  const double d2 = nu - p + 1.0;
  if (!(d2 > 4.0)) return {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
  const double a = p * nu / d2;  // T^2 = a F(p, d2)
  return {a * d2 / (d2 - 2.0), a * a * 2.0 * d2 * d2 * (p + d2 - 2.0) / (p * (d2 - 2.0) * (d2 - 2.0) * (d2 - 4.0))};
}

}  // namespace magnetometer_insitu_calibration
