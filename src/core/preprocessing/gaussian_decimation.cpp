#include "magnetometer_insitu_calibration/preprocessing/gaussian_decimation.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/time_steps.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

namespace magnetometer_insitu_calibration {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kGapFactor = 1.5;  ///< a step longer than 1.5 input periods is a gap

// The two predicates below decide, for batch and streaming alike, where a sample lies relative
// to the support [t_o - h, t_o + h] of output epoch t_o (same floating-point expressions in both).
bool before_support(double t, double t_o, double h) { return t - t_o < -h; }
bool after_support(double t, double t_o, double h) { return t - t_o > h; }

double epoch_time(long long j, double output_period_s) { return static_cast<double>(j) * output_period_s; }

/// Smallest j whose support starts after t_first (t_first is "before" it).
long long first_output_index(double t_first, double output_period_s, double h) {
  auto j = static_cast<long long>(std::floor((t_first + h) / output_period_s)) + 1;
  while (!before_support(t_first, epoch_time(j, output_period_s), h)) ++j;
  while (before_support(t_first, epoch_time(j - 1, output_period_s), h)) --j;
  return j;
}

/// Output at t_o from samples p..q of a time-ordered series, where p is the last sample before
/// the support and q the first after it. NaN when a step in p..q is a gap or a value is NaN.
template <class TimeAt, class ValueAt>
Eigen::Vector3d filter_output(double t_o, std::size_t p, std::size_t q, const TimeAt& time,
                              const ValueAt& value, double gap_s, double sigma_s) {
  const Eigen::Vector3d nan = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  for (std::size_t k = p; k < q; ++k) {
    if (time(k + 1) - time(k) > gap_s) return nan;
  }
  const double inv_two_sigma2 = 1.0 / (2.0 * sigma_s * sigma_s);
  double weight_sum = 0.0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t k = p + 1; k < q; ++k) {
    const Eigen::Vector3d x = value(k);
    if (!x.allFinite()) return nan;
    const double d = time(k) - t_o;
    const double w = std::exp(-d * d * inv_two_sigma2);
    weight_sum += w;
    sum += w * x;
  }
  if (!(weight_sum > 0.0)) return nan;
  return sum / weight_sum;
}

void check_kernel_covers_input(const DecimationSettings& settings, double input_period_s) {
  if (settings.half_width_s() < input_period_s) {
    std::ostringstream text;
    text << "kernel half-width " << settings.half_width_s() << " s (half_width_sigmas * sigma) is "
         << "shorter than the input period " << input_period_s << " s";
    throw InputError("sigma_s", text.str());
  }
}

}  // namespace

void DecimationSettings::validate() const {
  if (!(output_period_s > 0.0) || !std::isfinite(output_period_s)) {
    throw InputError("output_period_s", "must be positive and finite");
  }
  if (!(sigma_s >= 0.0) || !std::isfinite(sigma_s)) {
    throw InputError("sigma_s", "must be >= 0 (0 = default) and finite");
  }
  if (!(half_width_sigmas > 0.0) || !std::isfinite(half_width_sigmas)) {
    throw InputError("half_width_sigmas", "must be positive and finite");
  }
}

double DecimationSettings::effective_sigma_s() const {
  if (sigma_s > 0.0) return sigma_s;
  const double nyquist_hz = 0.5 / output_period_s;
  return std::sqrt(std::log(100.0) / 2.0) / (kPi * nyquist_hz);
}

double gaussian_gain(double sigma_s, double frequency_hz) {
  return std::exp(-2.0 * kPi * kPi * sigma_s * sigma_s * frequency_hz * frequency_hz);
}

VectorRecord decimate(const VectorRecord& input, const DecimationSettings& settings) {
  settings.validate();
  const std::string where = input.source.empty() ? std::string("decimation input") : input.source;
  const std::size_t n = input.time_s.size();
  if (static_cast<std::size_t>(input.values_nT.rows()) != n) {
    throw InputError(where, "times and values have different lengths");
  }
  if (n < 2) throw InputError(where, "need at least 2 samples to decimate, got " + std::to_string(n));
  std::vector<double> steps(n - 1);
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(input.time_s[i])) {
      throw InputError(where, "time stamp of sample " + std::to_string(i) + " is not finite");
    }
    if (i > 0) {
      steps[i - 1] = input.time_s[i] - input.time_s[i - 1];
      if (!(steps[i - 1] > 0.0)) {
        throw InputError(where, "time not increasing at sample " + std::to_string(i));
      }
    }
  }
  const auto middle = steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2);
  std::nth_element(steps.begin(), middle, steps.end());
  const double input_period_s = *middle;
  check_kernel_covers_input(settings, input_period_s);

  const double period = settings.output_period_s;
  const double sigma = settings.effective_sigma_s();
  const double h = settings.half_width_s();
  const double gap_s = kGapFactor * input_period_s;
  const std::vector<double>& t = input.time_s;
  auto time = [&](std::size_t k) { return t[k]; };
  auto value = [&](std::size_t k) -> Eigen::Vector3d {
    return input.values_nT.row(static_cast<Eigen::Index>(k)).transpose();
  };

  VectorRecord out;
  out.components = input.components;
  out.source = input.source;
  out.station = input.station;
  out.header = input.header;
  std::vector<Eigen::Vector3d> values;
  for (long long j = first_output_index(t.front(), period, h);; ++j) {
    const double t_o = epoch_time(j, period);
    if (!after_support(t.back(), t_o, h)) break;
    const std::size_t first_in = static_cast<std::size_t>(
        std::partition_point(t.begin(), t.end(), [&](double x) { return before_support(x, t_o, h); }) -
        t.begin());
    const std::size_t q = static_cast<std::size_t>(
        std::partition_point(t.begin() + static_cast<std::ptrdiff_t>(first_in), t.end(),
                             [&](double x) { return !after_support(x, t_o, h); }) -
        t.begin());
    out.time_s.push_back(t_o);
    values.push_back(filter_output(t_o, first_in - 1, q, time, value, gap_s, sigma));
  }
  out.values_nT.resize(static_cast<Eigen::Index>(values.size()), 3);
  for (std::size_t k = 0; k < values.size(); ++k) {
    out.values_nT.row(static_cast<Eigen::Index>(k)) = values[k].transpose();
  }
  return out;
}

ScalarRecord decimate_scalar(const ScalarRecord& input, const DecimationSettings& settings) {
  const std::size_t n = input.size();
  if (n < 2 || median_time_step(input.time_s) > kGapFactor * settings.output_period_s) return input;
  VectorRecord v;
  v.source = input.source;
  v.time_s = input.time_s;
  v.values_nT = Eigen::Map<const Eigen::VectorXd>(input.value_nT.data(), static_cast<Eigen::Index>(n)).replicate(1, 3);
  const VectorRecord d = decimate(v, settings);
  ScalarRecord out;
  out.source = input.source;
  out.station = input.station;
  out.time_s = d.time_s;
  out.value_nT.assign(d.values_nT.col(0).data(), d.values_nT.col(0).data() + d.values_nT.rows());
  return out;
}

StreamingDecimator::StreamingDecimator(double input_period_s, const DecimationSettings& settings,
                                       double restart_gap_s)
    : input_period_s_(input_period_s), restart_gap_s_(restart_gap_s) {
  settings.validate();
  if (!(input_period_s > 0.0) || !std::isfinite(input_period_s)) {
    throw InputError("input_period_s", "must be positive and finite");
  }
  if (!(restart_gap_s > 2.0 * settings.half_width_s())) {
    throw InputError("restart_gap_s", "must be longer than the kernel support (2 h)");
  }
  check_kernel_covers_input(settings, input_period_s);
  output_period_s_ = settings.output_period_s;
  sigma_s_ = settings.effective_sigma_s();
  half_width_s_ = settings.half_width_s();
}

void StreamingDecimator::reset() {
  time_s_.clear();
  value_nT_.clear();
  next_output_ = 0;
}

std::vector<std::pair<double, Eigen::Vector3d>> StreamingDecimator::push(double time_s,
                                                                        const Eigen::Vector3d& value_nT) {
  std::vector<std::pair<double, Eigen::Vector3d>> out;
  if (!std::isfinite(time_s)) {
    ++rejected_;
    return out;
  }
  if (!time_s_.empty() && std::abs(time_s - time_s_.back()) > restart_gap_s_) {
    reset();
    ++restarts_;
  } else if (!time_s_.empty() && !(time_s > time_s_.back())) {
    ++rejected_;
    return out;
  }
  const double h = half_width_s_;
  if (time_s_.empty()) next_output_ = first_output_index(time_s, output_period_s_, h);
  time_s_.push_back(time_s);
  value_nT_.push_back(value_nT);

  // Invariant: time_s_.front() lies before the support of the next output epoch.
  auto time = [this](std::size_t k) { return time_s_[k]; };
  auto value = [this](std::size_t k) -> Eigen::Vector3d { return value_nT_[k]; };
  const double gap_s = kGapFactor * input_period_s_;
  while (after_support(time_s, epoch_time(next_output_, output_period_s_), h)) {
    const double t_o = epoch_time(next_output_, output_period_s_);
    std::size_t p = 0;
    while (before_support(time_s_[p + 1], t_o, h)) ++p;
    std::size_t q = p + 1;
    while (!after_support(time_s_[q], t_o, h)) ++q;
    out.emplace_back(t_o, filter_output(t_o, p, q, time, value, gap_s, sigma_s_));
    ++next_output_;
    const double next_t_o = epoch_time(next_output_, output_period_s_);
    while (time_s_.size() >= 2 && before_support(time_s_[1], next_t_o, h)) {
      time_s_.pop_front();
      value_nT_.pop_front();
    }
  }
  return out;
}

}  // namespace magnetometer_insitu_calibration
