// Helpers shared by the simulator's known-truth tests (test_simulator*.cpp).
#pragma once

#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <Eigen/Core>
#include <fftw3.h>

#include <complex>
#include <vector>

namespace magnetometer_insitu_calibration::test {

// One-sided DFT X_k = sum_i x_i exp(-2 pi i k i / N), k = 0 .. N/2 (unnormalised).
inline std::vector<std::complex<double>> dft(const Eigen::VectorXd& x) {
  const int n = static_cast<int>(x.size());
  std::vector<double> in(x.data(), x.data() + n);
  std::vector<std::complex<double>> out(static_cast<std::size_t>(n / 2 + 1));
  fftw_plan plan = fftw_plan_dft_r2c_1d(n, in.data(), reinterpret_cast<fftw_complex*>(out.data()),
                                        FFTW_ESTIMATE);
  fftw_execute(plan);
  fftw_destroy_plan(plan);
  return out;
}

// A noise-free, artefact-free setting: T = B n_true exactly.
inline SimulationSettings quiet_settings() {
  SimulationSettings s;
  s.reference_white_nT = s.test_white_nT = 0.0;
  s.reference_pink_nT_per_sqrt_hz = s.test_pink_nT_per_sqrt_hz = 0.0;
  return s;
}

}  // namespace magnetometer_insitu_calibration::test
