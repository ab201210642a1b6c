#include "magnetometer_insitu_calibration/preprocessing/gap_filling.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

namespace magnetometer_insitu_calibration {
namespace {

constexpr const char* kWhere = "--reference/--test";
constexpr double kMaxGridEpochs = 2147483647.0;  // refuse grids that would not fit in memory

[[noreturn]] void fail_at(std::size_t index, double time_s, const std::string& problem) {
  std::ostringstream text;
  text.precision(15);
  text << "paired sample " << index << " (t = " << time_s << " s): " << problem;
  throw InputError(kWhere, text.str());
}

/// Median of the stamps' offsets from the grid through time_s[0], each in [-dt/2, dt/2].
double median_phase_offset(const std::vector<double>& time_s, double dt) {
  std::vector<double> offset(time_s.size());
  for (std::size_t i = 0; i < time_s.size(); ++i) {
    offset[i] = std::remainder(time_s[i] - time_s[0], dt);
  }
  const auto middle = offset.begin() + static_cast<std::ptrdiff_t>(offset.size() / 2);
  std::nth_element(offset.begin(), middle, offset.end());
  return *middle;
}

}  // namespace

GapReport regularize(PairedRecord& paired, double sample_period_s) {
  const double dt = sample_period_s;
  if (!(dt > 0.0) || !std::isfinite(dt)) throw InputError("sample_period_s", "must be positive and finite");
  const std::size_t n = paired.time_s.size();
  if (static_cast<std::size_t>(paired.reference_nT.rows()) != n ||
      static_cast<std::size_t>(paired.test_nT.rows()) != n) {
    throw InputError(kWhere, "paired record has times and values of different lengths");
  }
  if (n == 0) throw InputError(kWhere, "no paired samples");
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(paired.time_s[i])) fail_at(i, paired.time_s[i], "time is not finite");
    if (i > 0 && paired.time_s[i] <= paired.time_s[i - 1]) fail_at(i, paired.time_s[i], "time not increasing");
  }

  // 1. Grid and snapping.
  const double t0 = paired.time_s[0] + median_phase_offset(paired.time_s, dt);
  const double span_epochs = std::round((paired.time_s[n - 1] - t0) / dt);
  if (span_epochs + 1.0 > kMaxGridEpochs) {
    throw InputError(kWhere, "time span too long for a regular grid of " + std::to_string(dt) + " s");
  }
  // The first stamp may snap to epoch -1 when it is early by more than dt/2 - |median|; start
  // the grid at the first stamp's epoch.
  const long long k_first = std::llround((paired.time_s[0] - t0) / dt);
  const long long k_last = std::llround((paired.time_s[n - 1] - t0) / dt);
  const std::size_t grid_size = static_cast<std::size_t>(k_last - k_first + 1);
  const double grid_t0 = t0 + static_cast<double>(k_first) * dt;

  const double nan = std::numeric_limits<double>::quiet_NaN();
  Readings reference = Readings::Constant(static_cast<Eigen::Index>(grid_size), 3, nan);
  Readings test = Readings::Constant(static_cast<Eigen::Index>(grid_size), 3, nan);
  std::vector<std::uint8_t> present(grid_size, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const double t = paired.time_s[i];
    const long long k = std::llround((t - grid_t0) / dt);
    const double off = t - (grid_t0 + static_cast<double>(k) * dt);
    if (std::abs(off) > 0.25 * dt) {
      std::ostringstream text;
      text << off << " s off the " << dt << " s grid (more than a quarter period)";
      fail_at(i, t, text.str());
    }
    if (k < 0 || static_cast<std::size_t>(k) >= grid_size) fail_at(i, t, "outside the grid");
    const std::size_t row = static_cast<std::size_t>(k);
    if (present[row]) fail_at(i, t, "two samples snap to the same grid epoch");
    present[row] = 1;
    reference.row(static_cast<Eigen::Index>(row)) = paired.reference_nT.row(static_cast<Eigen::Index>(i));
    test.row(static_cast<Eigen::Index>(row)) = paired.test_nT.row(static_cast<Eigen::Index>(i));
  }

  GapReport report;
  report.inserted_epochs = grid_size - n;

  // 2. Mask: complete epochs have all six values finite.
  std::vector<std::uint8_t> complete(grid_size, 0);
  for (std::size_t k = 0; k < grid_size; ++k) {
    const auto r = static_cast<Eigen::Index>(k);
    complete[k] = reference.row(r).allFinite() && test.row(r).allFinite();
    if (!complete[k] && present[k]) ++report.masked_samples;
  }

  // 3. Trim.
  const auto first_it = std::find(complete.begin(), complete.end(), std::uint8_t{1});
  if (first_it == complete.end()) throw InputError(kWhere, "no epoch has all six components finite");
  const std::size_t first = static_cast<std::size_t>(first_it - complete.begin());
  std::size_t last = grid_size - 1;
  while (!complete[last]) --last;
  report.trimmed_leading = first;
  report.trimmed_trailing = grid_size - 1 - last;
  const std::size_t m = last - first + 1;

  paired.time_s.resize(m);
  for (std::size_t k = 0; k < m; ++k) paired.time_s[k] = grid_t0 + static_cast<double>(first + k) * dt;
  paired.reference_nT = reference.middleRows(static_cast<Eigen::Index>(first), static_cast<Eigen::Index>(m));
  paired.test_nT = test.middleRows(static_cast<Eigen::Index>(first), static_cast<Eigen::Index>(m));
  for (std::size_t k = 0; k < m; ++k) {
    if (complete[first + k]) continue;
    paired.reference_nT.row(static_cast<Eigen::Index>(k)).setConstant(nan);
    paired.test_nT.row(static_cast<Eigen::Index>(k)).setConstant(nan);
  }
  return report;
}

GapReport fill_gaps(PairedRecord& paired, double sample_period_s, const GapSettings& settings) {
  const double dt = sample_period_s;
  if (!(settings.max_fill_s >= 0.0)) throw InputError("max_fill_s", "must be >= 0");
  const std::size_t m = paired.time_s.size();
  std::vector<std::uint8_t> complete(m, 0);
  for (std::size_t k = 0; k < m; ++k) {
    const auto r = static_cast<Eigen::Index>(k);
    complete[k] = paired.reference_nT.row(r).allFinite() && paired.test_nT.row(r).allFinite();
  }
  GapReport report;
  report.filled.assign(m, 0);
  std::size_t k = 0;
  while (k < m) {
    if (complete[k]) {
      ++k;
      continue;
    }
    if (k == 0) throw InputError(kWhere, "fill_gaps: the record starts with an incomplete epoch (regularize first)");
    const std::size_t run_first = k;
    while (k < m && !complete[k]) ++k;
    if (k == m) throw InputError(kWhere, "fill_gaps: the record ends with an incomplete epoch (regularize first)");
    const std::size_t run_last = k - 1;
    const auto a = static_cast<Eigen::Index>(run_first - 1);  // complete epoch before the run
    const auto b = static_cast<Eigen::Index>(k);              // complete epoch after the run
    const double span = static_cast<double>(b - a);
    for (std::size_t j = run_first; j <= run_last; ++j) {
      const auto r = static_cast<Eigen::Index>(j);
      const double f = static_cast<double>(r - a) / span;
      paired.reference_nT.row(r) = paired.reference_nT.row(a) + f * (paired.reference_nT.row(b) - paired.reference_nT.row(a));
      paired.test_nT.row(r) = paired.test_nT.row(a) + f * (paired.test_nT.row(b) - paired.test_nT.row(a));
      report.filled[j] = 1;
    }
    const std::size_t missing = run_last - run_first + 1;
    report.filled_samples += missing;
    if (static_cast<double>(missing) * dt > settings.max_fill_s) {
      report.long_gaps.emplace_back(run_first, run_last);
    }
  }
  return report;
}

GapReport regularize_and_fill(PairedRecord& paired, double sample_period_s, const GapSettings& settings) {
  if (!(settings.max_fill_s >= 0.0)) throw InputError("max_fill_s", "must be >= 0");
  GapReport report = regularize(paired, sample_period_s);
  const GapReport filled = fill_gaps(paired, sample_period_s, settings);
  report.filled = filled.filled;
  report.filled_samples = filled.filled_samples;
  report.long_gaps = filled.long_gaps;
  return report;
}

}  // namespace magnetometer_insitu_calibration
