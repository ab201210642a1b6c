// A record advanced in time by a phase shift over the whole window (delay_estimation.hpp).
#include "magnetometer_insitu_calibration/estimation/delay_estimation.hpp"

#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"

#include <fftw3.h>

#include <cmath>
#include <complex>
#include <mutex>
#include <vector>

namespace magnetometer_insitu_calibration {

Readings advance_record(const Eigen::Ref<const Readings>& x, double sample_period_s, double advance_s) {
  Readings out = x;
  const auto n = static_cast<std::size_t>(x.rows());
  if (n < 4 || advance_s == 0.0) return out;
  std::vector<double> buffer(n);
  std::vector<fftw_complex> spectrum(n / 2 + 1);
  fftw_plan forward, backward;
  {
    std::lock_guard<std::mutex> lock(fftw_planner_lock());
    forward = fftw_plan_dft_r2c_1d(static_cast<int>(n), buffer.data(), spectrum.data(), FFTW_ESTIMATE);
    backward = fftw_plan_dft_c2r_1d(static_cast<int>(n), spectrum.data(), buffer.data(), FFTW_ESTIMATE);
  }
  const double df = 1.0 / (static_cast<double>(n) * sample_period_s);
  for (Eigen::Index k = 0; k < x.cols(); ++k) {
    const double first = x(0, k), last = x(static_cast<Eigen::Index>(n - 1), k);
    const double slope = (last - first) / (static_cast<double>(n - 1) * sample_period_s);  // nT/s
    for (std::size_t i = 0; i < n; ++i) {
      buffer[i] = x(static_cast<Eigen::Index>(i), k) - (first + slope * static_cast<double>(i) * sample_period_s);
    }
    fftw_execute(forward);
    for (std::size_t j = 0; j < n / 2 + 1; ++j) {
      const double phase = 2.0 * M_PI * static_cast<double>(j) * df * advance_s;
      const std::complex<double> y =
          std::complex<double>(spectrum[j][0], spectrum[j][1]) * std::polar(1.0, phase) / static_cast<double>(n);
      spectrum[j][0] = y.real();
      spectrum[j][1] = y.imag();
    }
    // The Nyquist term of a real series is real: its shifted cosine keeps the in-phase part.
    if (n % 2 == 0) spectrum[n / 2][1] = 0.0;
    fftw_execute(backward);
    for (std::size_t i = 0; i < n; ++i) {
      out(static_cast<Eigen::Index>(i), k) =
          buffer[i] + first + slope * (static_cast<double>(i) * sample_period_s + advance_s);
    }
  }
  {
    std::lock_guard<std::mutex> lock(fftw_planner_lock());
    fftw_destroy_plan(forward);
    fftw_destroy_plan(backward);
  }
  return out;
}

}  // namespace magnetometer_insitu_calibration
