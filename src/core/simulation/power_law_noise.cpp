// Reproducible random numbers and frequency-domain synthesis: see power_law_noise.hpp.
#include "magnetometer_insitu_calibration/simulation/power_law_noise.hpp"

#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"  // fftw_planner_lock()
#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <fftw3.h>

#include <cmath>
#include <mutex>
#include <new>
#include <stdexcept>
#include <string>

namespace magnetometer_insitu_calibration {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

}  // namespace

SimulationRng::SimulationRng(std::uint64_t seed, std::uint64_t stream)
    : engine_(splitmix64(splitmix64(seed) ^ splitmix64(stream + 0x632BE59BD9B4E019ULL))) {}

double SimulationRng::uniform() {
  return static_cast<double>(engine_() >> 11) * (1.0 / 9007199254740992.0);  // 2^-53
}

std::uint64_t SimulationRng::uniform_index(std::uint64_t n) {
  if (n == 0) throw std::invalid_argument("SimulationRng::uniform_index: n must be positive");
  const std::uint64_t limit = UINT64_MAX - UINT64_MAX % n;  // accept draws below limit
  std::uint64_t draw;
  do {
    draw = engine_();
  } while (draw >= limit);
  return draw % n;
}

double SimulationRng::normal() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  double u, v, s;
  do {
    u = 2.0 * uniform() - 1.0;
    v = 2.0 * uniform() - 1.0;
    s = u * u + v * v;
  } while (s >= 1.0 || s == 0.0);
  const double factor = std::sqrt(-2.0 * std::log(s) / s);
  spare_ = v * factor;
  has_spare_ = true;
  return u * factor;
}

Eigen::VectorXcd power_law_spectrum(std::size_t n, double sample_period_s, double spectral_index,
                                    double corner_hz, double psd_at_1hz, SimulationRng& rng) {
  if (n < 2) throw InputError("samples", "need at least 2 samples, got " + std::to_string(n));
  if (!(sample_period_s > 0.0) || !std::isfinite(sample_period_s)) {
    throw InputError("sample_period_s", "must be positive and finite");
  }
  if (!std::isfinite(spectral_index)) throw InputError("spectral_index", "must be finite");
  if (!(corner_hz >= 0.0) || !std::isfinite(corner_hz)) {
    throw InputError("corner_hz", "must be >= 0 and finite");
  }
  if (!(psd_at_1hz >= 0.0) || !std::isfinite(psd_at_1hz)) {
    throw InputError("psd_at_1hz", "must be >= 0 and finite");
  }
  const std::size_t half = n / 2 + 1;
  Eigen::VectorXcd spectrum = Eigen::VectorXcd::Zero(static_cast<Eigen::Index>(half));
  const double df = 1.0 / (static_cast<double>(n) * sample_period_s);
  // E|X_k|^2 = n S(f_k) / (2 dt); X_k = sqrt(that / 2) (g1 + i g2) with g standard normal.
  const double base = static_cast<double>(n) / (2.0 * sample_period_s);
  const std::size_t last = (n % 2 == 0) ? half - 1 : half;  // Nyquist harmonic left at zero
  for (std::size_t k = 1; k < last; ++k) {
    const double f = static_cast<double>(k) * df;
    const double psd = psd_at_1hz * std::pow(f * f + corner_hz * corner_hz, -0.5 * spectral_index);
    const double sigma = std::sqrt(0.5 * base * psd);
    const double re = rng.normal();
    const double im = rng.normal();
    spectrum(static_cast<Eigen::Index>(k)) = std::complex<double>(sigma * re, sigma * im);
  }
  return spectrum;
}

SpectralSynthesizer::SpectralSynthesizer(std::size_t n) : n_(n) {
  if (n < 2) throw InputError("samples", "need at least 2 samples, got " + std::to_string(n));
  in_ = reinterpret_cast<std::complex<double>*>(fftw_malloc(sizeof(fftw_complex) * (n / 2 + 1)));
  out_ = static_cast<double*>(fftw_malloc(sizeof(double) * n));
  if (in_ == nullptr || out_ == nullptr) {
    fftw_free(in_);
    fftw_free(out_);
    throw std::bad_alloc();
  }
  std::lock_guard<std::mutex> lock(fftw_planner_lock());
  plan_ = fftw_plan_dft_c2r_1d(static_cast<int>(n), reinterpret_cast<fftw_complex*>(in_), out_,
                               FFTW_ESTIMATE);
  if (plan_ == nullptr) {
    fftw_free(in_);
    fftw_free(out_);
    throw std::runtime_error("FFTW could not plan a c2r transform of size " + std::to_string(n));
  }
}

SpectralSynthesizer::~SpectralSynthesizer() {
  {
    std::lock_guard<std::mutex> lock(fftw_planner_lock());
    fftw_destroy_plan(static_cast<fftw_plan>(plan_));
  }
  fftw_free(in_);
  fftw_free(out_);
}

Eigen::VectorXd SpectralSynthesizer::synthesize(const Eigen::VectorXcd& spectrum,
                                                double sample_period_s, double delay_s) {
  const std::size_t half = n_ / 2 + 1;
  if (static_cast<std::size_t>(spectrum.size()) != half) {
    throw std::invalid_argument("SpectralSynthesizer::synthesize: spectrum has " +
                                std::to_string(spectrum.size()) + " harmonics, expected " +
                                std::to_string(half));
  }
  const double n = static_cast<double>(n_);
  for (std::size_t k = 0; k < half; ++k) {
    std::complex<double> value = spectrum(static_cast<Eigen::Index>(k));
    if (delay_s != 0.0) {
      // f_k delay = k delay / (n dt); reduce the cycles to [0, 1) before the trigonometry.
      double cycles = static_cast<double>(k) * (delay_s / (n * sample_period_s));
      cycles -= std::floor(cycles);
      value *= std::polar(1.0, -2.0 * kPi * cycles);
    }
    in_[k] = value;
  }
  fftw_execute(static_cast<fftw_plan>(plan_));
  Eigen::VectorXd series(static_cast<Eigen::Index>(n_));
  const double scale = 1.0 / n;
  for (std::size_t i = 0; i < n_; ++i) series(static_cast<Eigen::Index>(i)) = out_[i] * scale;
  return series;
}

void add_instrument_noise(Readings& values, double white_nT, double pink_nT_per_sqrt_hz, double dt,
                          SimulationRng& rng, SpectralSynthesizer& synthesizer) {
  const std::size_t n = static_cast<std::size_t>(values.rows());
  for (int c = 0; c < 3; ++c) {
    if (pink_nT_per_sqrt_hz > 0.0) {
      const Eigen::VectorXcd spectrum =
          power_law_spectrum(n, dt, 1.0, 0.0, pink_nT_per_sqrt_hz * pink_nT_per_sqrt_hz, rng);
      values.col(c) += synthesizer.synthesize(spectrum, dt);
    }
    if (white_nT > 0.0) {
      for (std::size_t i = 0; i < n; ++i) values(static_cast<Eigen::Index>(i), c) += white_nT * rng.normal();
    }
  }
}

}  // namespace magnetometer_insitu_calibration
