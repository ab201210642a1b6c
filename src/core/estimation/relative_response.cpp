#include "magnetometer_insitu_calibration/estimation/relative_response.hpp"

#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "spectral_tools.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <functional>
#include <limits>

namespace magnetometer_insitu_calibration {
namespace {

constexpr double kPi = 3.14159265358979323846;

}  // namespace

namespace {

/// First difference, then a 10 % split-cosine bell (5 % at each end), in place on a copy.
Eigen::VectorXd whitened_tapered(const Eigen::VectorXd& x) {
  const Eigen::Index n = x.size() - 1;
  Eigen::VectorXd d = x.tail(n) - x.head(n);
  const Eigen::Index edge = std::max<Eigen::Index>(1, n / 20);
  for (Eigen::Index i = 0; i < edge; ++i) {
    const double w = 0.5 * (1.0 - std::cos(kPi * (static_cast<double>(i) + 0.5) / static_cast<double>(edge)));
    d(i) *= w;
    d(n - 1 - i) *= w;
  }
  return d;
}

/// H of one component over the band's harmonics [j0, j1): H0 at f_band, and Var(H0).
struct BandFit {
  std::complex<double> h0;
  double var_h0 = 0.0;
};

/// sum |T - P (H0 + H1 u)|^2 over the band's harmonics: the fit's residual power.
double band_residual(const Eigen::VectorXcd& p_dft, const Eigen::VectorXcd& t_dft, std::size_t j0, std::size_t j1,
                     double f_band, double df, const Eigen::Vector2cd& h) {
  double residual = 0.0;
  for (std::size_t j = j0; j < j1; ++j) {
    const auto jj = static_cast<Eigen::Index>(j);
    residual += std::norm(t_dft(jj) - p_dft(jj) * (h(0) + h(1) * ((static_cast<double>(j) * df - f_band) / df)));
  }
  return residual;
}

/// H varies across a band (a filter's phase turns with frequency): a band average would be
/// biased where it turns fastest. So H is fitted as H0 + H1 (f - f_band) over the band's
/// harmonics (complex least squares, 2 parameters) and H0 is the response at f_band. With
/// `noise` (the reference noise's expected |P|^2 at f), X^H X is corrected for it where it stays
/// positive definite. Var(H0) = sigma^2 [(X^H X)^-1]_00, sigma^2 = residual / (M - 2).
BandFit band_fit(const Eigen::VectorXcd& p_dft, const Eigen::VectorXcd& t_dft, std::size_t j0, std::size_t j1,
                 double f_band, double df, const std::function<double(double)>& noise_power) {
  Eigen::Matrix2cd xhx = Eigen::Matrix2cd::Zero();
  Eigen::Vector2cd xht = Eigen::Vector2cd::Zero();
  Eigen::Matrix2d noise = Eigen::Matrix2d::Zero();  // E of the reference noise's share of X^H X
  for (std::size_t j = j0; j < j1; ++j) {
    const auto jj = static_cast<Eigen::Index>(j);
    const double u = (static_cast<double>(j) * df - f_band) / df;
    const Eigen::Vector2cd x(p_dft(jj), p_dft(jj) * u);
    xhx += x.conjugate() * x.transpose();
    xht += x.conjugate() * t_dft(jj);
    if (noise_power) noise += noise_power(static_cast<double>(j) * df) * Eigen::Vector2d(1.0, u) * Eigen::RowVector2d(1.0, u);
  }
  if (noise_power) {
    const Eigen::Matrix2cd corrected = xhx - noise.cast<std::complex<double>>();
    // Positive definite (the noise below the signal in both directions), else uncorrected.
    if (corrected(0, 0).real() > 0.0 && corrected.determinant().real() > 0.0) xhx = corrected;
  }
  const Eigen::Matrix2cd inverse = xhx.inverse();
  const Eigen::Vector2cd h = inverse * xht;
  const double residual = band_residual(p_dft, t_dft, j0, j1, f_band, df, h);
  return {h(0), residual / (static_cast<double>(j1 - j0) - 2.0) * std::abs(inverse(0, 0))};
}

/// The same with the remote's prediction of P as the instrument (relative_response.hpp).
BandFit band_fit_remote(const Eigen::VectorXcd& p_dft, const Eigen::VectorXcd& t_dft,
                        const std::array<Eigen::VectorXcd, 3>& z_dft, std::size_t j0, std::size_t j1, double f_band,
                        double df) {
  // First stage: P ~ Z b over the band.
  Eigen::Matrix3cd zhz = Eigen::Matrix3cd::Zero();
  Eigen::Vector3cd zhp = Eigen::Vector3cd::Zero();
  for (std::size_t j = j0; j < j1; ++j) {
    const auto jj = static_cast<Eigen::Index>(j);
    const Eigen::Vector3cd z(z_dft[0](jj), z_dft[1](jj), z_dft[2](jj));
    zhz += z.conjugate() * z.transpose();
    zhp += z.conjugate() * p_dft(jj);
  }
  const Eigen::Vector3cd b = zhz.ldlt().solve(zhp);
  Eigen::Matrix2cd qhx = Eigen::Matrix2cd::Zero(), qhq = Eigen::Matrix2cd::Zero();
  Eigen::Vector2cd qht = Eigen::Vector2cd::Zero();
  for (std::size_t j = j0; j < j1; ++j) {
    const auto jj = static_cast<Eigen::Index>(j);
    const double u = (static_cast<double>(j) * df - f_band) / df;
    const std::complex<double> q = z_dft[0](jj) * b(0) + z_dft[1](jj) * b(1) + z_dft[2](jj) * b(2);
    const Eigen::Vector2cd x(p_dft(jj), p_dft(jj) * u), w(q, q * u);
    qhx += w.conjugate() * x.transpose();
    qhq += w.conjugate() * w.transpose();
    qht += w.conjugate() * t_dft(jj);
  }
  const Eigen::Matrix2cd inverse = qhx.inverse();
  const Eigen::Vector2cd h = inverse * qht;
  const double residual = band_residual(p_dft, t_dft, j0, j1, f_band, df, h);
  const Eigen::Matrix2cd bread = inverse * qhq * inverse.adjoint();
  return {h(0), residual / (static_cast<double>(j1 - j0) - 2.0) * std::abs(bread(0, 0))};
}

}  // namespace

void RelativeResponseSettings::validate() const {
  if (!(low_hz > 0.0) || !std::isfinite(low_hz)) throw InputError("relative_response.low_hz", "must be > 0 Hz");
  if (!(high_hz > low_hz) || !std::isfinite(high_hz)) {
    throw InputError("relative_response.high_hz", "must be finite and above low_hz");
  }
  if (bands_per_decade < 1 || bands_per_decade > 100) {
    throw InputError("relative_response.bands_per_decade", "must be 1 to 100");
  }
  if (min_harmonics < 3) throw InputError("relative_response.min_harmonics", "must be >= 3");
}

std::vector<ResponseBand> relative_response(const Readings& reference, const Readings& test,
                                            const Eigen::Matrix3d& n, double period_s,
                                            const RelativeResponseSettings& settings, const Readings* remote) {
  settings.validate();
  if (reference.rows() != test.rows() || (remote != nullptr && remote->rows() != reference.rows())) {
    throw InputError("relative_response", "reference, test and remote differ in length");
  }
  if (!(period_s > 0.0)) throw InputError("relative_response", "sample period must be > 0 s");
  std::vector<ResponseBand> out;
  if (reference.rows() < 16) return out;

  thread_local Readings predicted;  // R n, nT; kept per thread with the spectra below
  predicted.noalias() = reference * n;
  // The N - 1 differences, transformed zero-padded to the record's length N (a fast FFT length
  // where N - 1 seldom is; the taper is ~0 at the ends): harmonic j at j / (N dt).
  const auto length = static_cast<std::size_t>(reference.rows() - 1);
  const std::size_t padded = length + 1;
  detail::RealDft& dft = detail::thread_real_dft();
  thread_local std::array<Eigen::VectorXcd, 3> p_dft, t_dft, z_dft;
  for (int k = 0; k < 3; ++k) {
    const Eigen::VectorXd p = whitened_tapered(predicted.col(k));
    const Eigen::VectorXd t = whitened_tapered(test.col(k));
    dft.transform(p.data(), length, padded, p_dft[k]);
    dft.transform(t.data(), length, padded, t_dft[k]);
    if (remote == nullptr) continue;
    const Eigen::VectorXd z = whitened_tapered(remote->col(k));
    dft.transform(z.data(), length, padded, z_dft[k]);
  }
  const double df = 1.0 / (static_cast<double>(padded) * period_s);  // harmonic spacing, Hz
  // Errors in variables: E|P_noise,k(j)|^2 of the differenced, tapered DFT of L samples is
  // L / (2 dt) * sum_i n_ik^2 S_r,i(f) * 4 sin^2(pi f dt) * mean(taper^2); the 10 % split-cosine
  // bell has mean(taper^2) = 0.9 + 0.1 * 3/8.
  const bool eiv = remote == nullptr && ((settings.reference_noise.white_nT.array() != 0.0).any() ||
                                          (settings.reference_noise.pink_nT_per_sqrt_hz.array() != 0.0).any());
  const Eigen::Matrix3d n2 = n.cwiseAbs2();
  const auto noise_power = [&](double f, int k) {
    const double s = std::sin(kPi * f * period_s);
    return n2.col(k).dot(settings.reference_noise.expected_periodogram(f, period_s, length)) * 4.0 * s * s * 0.9375;
  };
  const double top = std::min(settings.high_hz, 0.9 * 0.5 / period_s);
  const double step = 1.0 / settings.bands_per_decade;
  for (double lg = std::log10(settings.low_hz); lg < std::log10(top) - 1e-12; lg += step) {
    ResponseBand band;
    band.low_hz = std::pow(10.0, lg);
    band.high_hz = std::min(top, std::pow(10.0, lg + step));
    const auto j0 = static_cast<std::size_t>(std::ceil(band.low_hz / df));
    const auto j1 = std::min(static_cast<std::size_t>(std::ceil(band.high_hz / df)),
                             static_cast<std::size_t>(p_dft[0].size()));  // [j0, j1)
    if (j0 == 0 || j1 <= j0 || j1 - j0 < settings.min_harmonics) continue;
    band.harmonics = j1 - j0;
    const double m = static_cast<double>(band.harmonics);
    // The band's frequency: the |P|^2-weighted mean over the three components' harmonics.
    double weighted_f = 0.0, total_power = 0.0;
    for (int k = 0; k < 3; ++k) {
      for (std::size_t j = j0; j < j1; ++j) {
        const double w = std::norm(p_dft[k](static_cast<Eigen::Index>(j)));
        weighted_f += w * static_cast<double>(j) * df;
        total_power += w;
      }
    }
    band.frequency_hz = total_power > 0.0 ? weighted_f / total_power : std::sqrt(band.low_hz * band.high_hz);
    for (int k = 0; k < 3; ++k) {
      const BandFit fit = remote != nullptr ? band_fit_remote(p_dft[k], t_dft[k], z_dft, j0, j1, band.frequency_hz, df)
                                            : band_fit(p_dft[k], t_dft[k], j0, j1, band.frequency_hz, df,
                                                       eiv ? [&](double f) { return noise_power(f, k); }
                                                           : std::function<double(double)>());
      // Half of Var(H0) in the real (gain) and half in the imaginary (phase) direction of H0.
      const double half = student_t_two_sided_quantile(0.05, 2.0 * (m - 2.0)) * std::sqrt(0.5 * fit.var_h0);
      const double gain = std::abs(fit.h0);
      band.gain(k) = gain;
      band.gain_ci95(k) = half;
      band.phase_deg(k) = std::arg(fit.h0) * 180.0 / kPi;
      band.phase_ci95_deg(k) = gain > 0.0 ? std::min(180.0, half / gain * 180.0 / kPi) : 180.0;
    }
    out.push_back(band);
  }
  return out;
}

ResponseSummary summarise_response(const std::vector<ResponseBand>& bands, double low_hz, double high_hz) {
  ResponseSummary s;
  double num = 0.0, den = 0.0;
  for (const auto& b : bands) {
    if (b.frequency_hz < low_hz || b.frequency_hz > high_hz) continue;
    ++s.bands;
    for (int k = 0; k < 3; ++k) {
      if (std::abs(b.gain(k) - 1.0) > s.max_gain_departure) {
        s.max_gain_departure = std::abs(b.gain(k) - 1.0);
        s.max_gain_departure_ci95 = b.gain_ci95(k);
      }
      // phase = -omega tau: weighted least squares through the origin, weights 1 / var(phase).
      const double omega = 2.0 * kPi * b.frequency_hz;
      // The band's standard error: its half-width over the quantile that made it.
      const double t = student_t_two_sided_quantile(0.05, 2.0 * (static_cast<double>(b.harmonics) - 2.0));
      const double sd = std::max(1e-9, b.phase_ci95_deg(k) / t * kPi / 180.0);
      const double w = 1.0 / (sd * sd);
      num += w * omega * (-b.phase_deg(k) * kPi / 180.0);
      den += w * omega * omega;
    }
  }
  if (s.bands == 0) {
    s.max_gain_departure = std::numeric_limits<double>::quiet_NaN();
    s.max_gain_departure_ci95 = std::numeric_limits<double>::quiet_NaN();
    s.group_delay_s = std::numeric_limits<double>::quiet_NaN();
  } else {
    s.group_delay_s = num / den;
  }
  return s;
}

}  // namespace magnetometer_insitu_calibration
