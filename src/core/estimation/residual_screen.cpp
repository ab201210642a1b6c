// Residual screen of the robust estimator (robust_estimator.hpp, step 1): flags the samples
// where T - R n, high-passed by a running median, is an outlier.
#include "magnetometer_insitu_calibration/estimation/robust_estimator.hpp"

#include "spectral_tools.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace magnetometer_insitu_calibration {

namespace {

/// Running-median baseline of x (one column), evaluated at block centres every `step` samples
/// over `window` samples and interpolated linearly: O(N window / step).
Eigen::VectorXd running_median_baseline(const Eigen::VectorXd& x, std::size_t window, std::size_t step) {
  const std::size_t n = static_cast<std::size_t>(x.size());
  Eigen::VectorXd base(x.size());
  if (n == 0) return base;
  window = std::min(window, n);
  std::vector<double> centres, values, buffer;
  for (std::size_t c = 0;; c += step) {
    const std::size_t centre = std::min(c, n - 1);
    const std::size_t first = centre >= window / 2 ? centre - window / 2 : 0;
    const std::size_t last = std::min(n, first + window);
    buffer.assign(x.data() + first, x.data() + last);
    centres.push_back(static_cast<double>(centre));
    values.push_back(detail::median(buffer));
    if (centre == n - 1) break;
  }
  std::size_t k = 0;
  for (std::size_t i = 0; i < n; ++i) {
    while (k + 1 < centres.size() && centres[k + 1] < static_cast<double>(i)) ++k;
    if (k + 1 >= centres.size()) {
      base(static_cast<Eigen::Index>(i)) = values.back();
      continue;
    }
    const double a = (static_cast<double>(i) - centres[k]) / (centres[k + 1] - centres[k]);
    base(static_cast<Eigen::Index>(i)) = values[k] + std::clamp(a, 0.0, 1.0) * (values[k + 1] - values[k]);
  }
  return base;
}

}  // namespace

std::vector<char> screen_residual(const Eigen::Ref<const Readings>& reference_nT, const Eigen::Ref<const Readings>& test_nT,
                                  const Eigen::Matrix3d& n, double sample_period_s, const RobustSettings& settings) {
  const std::size_t length = static_cast<std::size_t>(reference_nT.rows());
  std::vector<char> mask(length, 0);
  if (length < 16 || !n.allFinite()) return mask;
  const Readings residual = test_nT - reference_nT * n;
  const std::size_t window = std::max<std::size_t>(3, static_cast<std::size_t>(std::llround(settings.screen_baseline_s / sample_period_s)));
  const std::size_t step = std::max<std::size_t>(1, window / 10);
  const std::size_t margin = static_cast<std::size_t>(std::llround(settings.screen_margin_s / sample_period_s));
  std::vector<char> flag(length, 0);
  for (int c = 0; c < 3; ++c) {
    const Eigen::VectorXd e = residual.col(c);
    const Eigen::VectorXd hp = e - running_median_baseline(e, window, step);
    std::vector<double> abs_dev(length);
    const double centre = detail::median(std::vector<double>(hp.data(), hp.data() + length));
    for (std::size_t i = 0; i < length; ++i) abs_dev[i] = std::abs(hp(static_cast<Eigen::Index>(i)) - centre);
    const double sigma = 1.4826 * detail::median(abs_dev);
    if (!(sigma > 0.0)) continue;
    for (std::size_t i = 0; i < length; ++i) flag[i] |= abs_dev[i] > settings.screen_threshold * sigma;
  }
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
