// Reproducible random numbers and power-law (f^-alpha) series synthesised in the frequency
// domain with FFTW: the building blocks of the simulator.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <Eigen/Core>

#include <complex>
#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

namespace magnetometer_insitu_calibration {

/// std::mt19937_64 (whose output sequence is fixed by the standard) with our own uniform and
/// normal transforms, so that a seed gives the same numbers with every standard library
/// (std::normal_distribution is implementation-defined).
class SimulationRng {
 public:
  /// The engine is seeded with splitmix64(seed, stream): independent streams from one seed,
  /// so that e.g. changing the spike settings does not change the noise.
  explicit SimulationRng(std::uint64_t seed, std::uint64_t stream = 0);
  /// Uniform in [0, 1), 53 random bits.
  double uniform();
  /// Uniform integer in [0, n) (n > 0), by rejection (no modulo bias).
  std::uint64_t uniform_index(std::uint64_t n);
  /// Standard normal (mean 0, variance 1), Marsaglia polar method.
  double normal();

 private:
  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

/// One-sided spectrum (harmonics k = 0 .. n/2 of an n-sample series, sample period dt) of a
/// random series whose one-sided power spectral density is
///   S(f) = psd_at_1hz * ((f^2 + corner_hz^2) / (1 Hz)^2)^(-spectral_index / 2)   [nT^2/Hz],
/// i.e. S = psd_at_1hz * f^-spectral_index for f >> corner_hz. Coefficients are complex normal
/// with E|X_k|^2 = n S(f_k) / (2 dt), the scaling of an unnormalised DFT, so that
/// synthesize(...) / n has that PSD. The mean (k = 0) and, for even n, the Nyquist harmonic are
/// zero, so that a fractional delay is an exact phase shift (see synthesize).
Eigen::VectorXcd power_law_spectrum(std::size_t n, double sample_period_s, double spectral_index,
                                    double corner_hz, double psd_at_1hz, SimulationRng& rng);

/// Real series from one-sided spectra, by FFTW c2r transforms of one size (plan made once).
/// Plan creation and destruction take fftw_planner_lock() (fd_wlse.hpp), like every FFTW plan
/// in the core, so synthesizers may be made in several threads; one instance per thread.
class SpectralSynthesizer {
 public:
  explicit SpectralSynthesizer(std::size_t n);
  ~SpectralSynthesizer();
  SpectralSynthesizer(const SpectralSynthesizer&) = delete;
  SpectralSynthesizer& operator=(const SpectralSynthesizer&) = delete;

  /// x_i = (1/n) sum_k X_k exp(2 pi i k i/n) evaluated at time i*dt - delay_s: each harmonic is
  /// multiplied by exp(-2 pi i f_k delay_s), f_k = k / (n dt). The series is the band-limited
  /// periodic function defined by the spectrum, so the delay is exact (circular).
  Eigen::VectorXd synthesize(const Eigen::VectorXcd& spectrum, double sample_period_s,
                             double delay_s = 0.0);

  std::size_t size() const { return n_; }

 private:
  std::size_t n_;
  std::complex<double>* in_ = nullptr;
  double* out_ = nullptr;
  void* plan_ = nullptr;
};

/// An instrument's noise added to `values` (nT, sample period dt s), column by column: 1/f noise
/// of amplitude spectral density pink_nT_per_sqrt_hz at 1 Hz (none when 0), then white noise of
/// white_nT rms per sample (none when 0), drawn from `rng` in that order. The simulator's
/// instruments, and a real field's simulated instruments (monte_carlo_real_field).
void add_instrument_noise(Readings& values, double white_nT, double pink_nT_per_sqrt_hz, double dt,
                          SimulationRng& rng, SpectralSynthesizer& synthesizer);

}  // namespace magnetometer_insitu_calibration
