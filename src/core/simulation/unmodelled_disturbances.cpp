// Test-only disturbances the estimators do not model: see unmodelled_disturbances.hpp.
#include "magnetometer_insitu_calibration/simulation/unmodelled_disturbances.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"  // fftw_planner_lock()

#include <fftw3.h>

#include <cmath>
#include <complex>
#include <mutex>
#include <random>
#include <vector>

namespace magnetometer_insitu_calibration {

void UnmodelledDisturbanceSettings::validate() const {
  if (!(test_corner_hz >= 0.0) || !std::isfinite(test_corner_hz)) throw InputError("test_corner_hz", "must be >= 0 Hz (0: no filter)");
  if (!std::isfinite(test_delay_s)) throw InputError("test_delay_s", "must be a finite time in s");
  if (!(tilt_walk_nT_per_sqrt_day >= 0.0) || !std::isfinite(tilt_walk_nT_per_sqrt_day))
    throw InputError("tilt_walk_nT_per_sqrt_day", "must be >= 0 nT/sqrt(day)");
  if (!heater_nT.allFinite()) throw InputError("heater_nT", "must be finite (nT, test frame)");
  if (!(heater_period_s > 0.0) || !std::isfinite(heater_period_s)) throw InputError("heater_period_s", "must be > 0 s");
  if (!(heater_period_jitter >= 0.0 && heater_period_jitter <= 0.9))
    throw InputError("heater_period_jitter", "must be in [0, 0.9]");
  if (!(heater_duty > 0.0 && heater_duty < 1.0)) throw InputError("heater_duty", "must be in (0, 1)");
  if (!(heater_time_constant_s > 0.0) || !std::isfinite(heater_time_constant_s))
    throw InputError("heater_time_constant_s", "must be > 0 s");
}

void apply_test_response(Readings& values, double dt, double corner_hz, double delay_s) {
  const std::size_t n = static_cast<std::size_t>(values.rows());
  if (n < 4 || (corner_hz == 0.0 && delay_s == 0.0)) return;
  const double duration = static_cast<double>(n) * dt;
  std::vector<double> x(n);
  std::vector<std::complex<double>> spectrum(n / 2 + 1);
  fftw_plan forward, backward;
  {
    std::lock_guard<std::mutex> lock(fftw_planner_lock());
    forward = fftw_plan_dft_r2c_1d(static_cast<int>(n), x.data(), reinterpret_cast<fftw_complex*>(spectrum.data()),
                                   FFTW_ESTIMATE);
    backward = fftw_plan_dft_c2r_1d(static_cast<int>(n), reinterpret_cast<fftw_complex*>(spectrum.data()), x.data(),
                                    FFTW_ESTIMATE);
  }
  // Delay of the line through the filter: its low-frequency group delay, 1 / (2 pi corner).
  const double line_delay_s = delay_s + (corner_hz > 0.0 ? 1.0 / (2.0 * M_PI * corner_hz) : 0.0);
  for (int c = 0; c < 3; ++c) {
    // Fill NaN runs by straight lines (flat at the ends), remembering them.
    std::vector<char> missing(n, 0);
    for (std::size_t i = 0; i < n; ++i) {
      x[i] = values(static_cast<Eigen::Index>(i), c);
      missing[i] = !std::isfinite(x[i]);
    }
    std::size_t i = 0;
    while (i < n) {
      if (!missing[i]) {
        ++i;
        continue;
      }
      std::size_t j = i;
      while (j < n && missing[j]) ++j;
      const bool left = i > 0, right = j < n;
      if (!left && !right) return;  // nothing to filter in this record
      for (std::size_t k = i; k < j; ++k) {
        const double a = static_cast<double>(k - i + 1) / static_cast<double>(j - i + 1);
        x[k] = left && right ? x[i - 1] + a * (x[j] - x[i - 1]) : (left ? x[i - 1] : x[j]);
      }
      i = j;
    }
    // Line through the first and last sample: x = line + r, r(0) = r(N-1) = 0 (no wrap jump).
    const double first = x[0], slope = (x[n - 1] - x[0]) / (static_cast<double>(n - 1) * dt);  // nT/s
    for (std::size_t k = 0; k < n; ++k) x[k] -= first + slope * static_cast<double>(k) * dt;
    fftw_execute(forward);
    for (std::size_t k = 0; k < spectrum.size(); ++k) {
      const double f = static_cast<double>(k) / duration;
      std::complex<double> h = std::polar(1.0, -2.0 * M_PI * f * delay_s);
      if (corner_hz > 0.0) h /= std::complex<double>(1.0, f / corner_hz);
      if (2 * k == n) h = std::abs(h);  // Nyquist bin: real
      spectrum[k] *= h / static_cast<double>(n);
    }
    fftw_execute(backward);
    for (std::size_t k = 0; k < n; ++k) {
      const double line = first + slope * (static_cast<double>(k) * dt - line_delay_s);
      values(static_cast<Eigen::Index>(k), c) = missing[k] ? std::nan("") : x[k] + line;
    }
  }
  std::lock_guard<std::mutex> lock(fftw_planner_lock());
  fftw_destroy_plan(forward);
  fftw_destroy_plan(backward);
}

UnmodelledDisturbanceReport add_unmodelled_disturbances(SimulatedPair& pair, const UnmodelledDisturbanceSettings& s) {
  s.validate();
  const std::size_t n = pair.test.size();
  const Eigen::Index rows = static_cast<Eigen::Index>(n);
  const double dt = n > 1 ? pair.test.time_s[1] - pair.test.time_s[0] : 1.0;
  std::mt19937_64 rng(s.seed * 0xD1B54A32D192ED03ULL + 777);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  UnmodelledDisturbanceReport report;
  report.tilt_added_nT = Readings::Zero(rows, 3);
  report.heater_added_nT = Readings::Zero(rows, 3);

  // Tilt walk: B [theta]x n(t), B the reference reading (last finite one across reference gaps).
  if (s.tilt_walk_nT_per_sqrt_day > 0.0) {
    Eigen::RowVector3d mean = Eigen::RowVector3d::Zero();
    std::size_t finite = 0;
    for (Eigen::Index r = 0; r < rows; ++r) {
      if (pair.reference.values_nT.row(r).allFinite()) {
        mean += pair.reference.values_nT.row(r);
        ++finite;
      }
    }
    if (finite == 0) throw InputError("reference", "no finite sample: the tilt walk needs the field");
    mean /= static_cast<double>(finite);
    const double step_rad = s.tilt_walk_nT_per_sqrt_day / mean.norm() * std::sqrt(dt / 86400.0);
    Eigen::Vector2d theta = Eigen::Vector2d::Zero();
    Eigen::RowVector3d b = mean;
    for (Eigen::Index r = 0; r < rows; ++r) {
      if (r > 0) theta += step_rad * Eigen::Vector2d(normal(rng), normal(rng));
      if (pair.reference.values_nT.row(r).allFinite()) b = pair.reference.values_nT.row(r);
      Eigen::Matrix3d cross;  // [theta]x with theta = (theta_x, theta_y, 0)
      cross << 0.0, 0.0, theta(1),  //
          0.0, 0.0, -theta(0),      //
          -theta(1), theta(0), 0.0;
      report.tilt_added_nT.row(r) = b * cross * pair.n_at(pair.test.time_s[static_cast<std::size_t>(r)]);
    }
    report.tilt_end_rad = theta;
  }

  // Heater: on for duty x cycle, first-order approach to heater_nT (on) or 0 (off).
  if (!s.heater_nT.isZero()) {
    const double duration = static_cast<double>(n) * dt;
    double cycle_start = -uniform(rng) * s.heater_period_s;  // random phase
    double level = 0.0;  // 0..1
    std::size_t k = 0;
    const double decay = std::exp(-dt / s.heater_time_constant_s);
    while (cycle_start < duration) {
      const double length = s.heater_period_s * (1.0 + s.heater_period_jitter * (2.0 * uniform(rng) - 1.0));
      const double off_at = cycle_start + s.heater_duty * length;
      for (; k < n && static_cast<double>(k) * dt < cycle_start + length; ++k) {
        const double target = static_cast<double>(k) * dt < off_at ? 1.0 : 0.0;
        level = target + (level - target) * decay;
        report.heater_added_nT.row(static_cast<Eigen::Index>(k)) = level * s.heater_nT.transpose();
      }
      cycle_start += length;
      ++report.heater_cycles;
    }
  }
  pair.test.values_nT += report.tilt_added_nT + report.heater_added_nT;  // NaN stays NaN

  // Response mismatch, with the simulator's test glitches taken out and put back unfiltered.
  if (s.test_corner_hz > 0.0 || s.test_delay_s != 0.0) {
    auto glitches = [&](double sign) {
      for (const SimulatedSpike& spike : pair.spikes) {
        if (spike.instrument == SimulatedInstrument::kReference) continue;
        pair.test.values_nT(static_cast<Eigen::Index>(spike.index), spike.component) += sign * spike.amplitude_nT;
      }
    };
    glitches(-1.0);
    apply_test_response(pair.test.values_nT, dt, s.test_corner_hz, s.test_delay_s);
    glitches(+1.0);
  }
  return report;
}

}  // namespace magnetometer_insitu_calibration
