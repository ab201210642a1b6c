// Delay between the instruments from the cross-spectral phase: see delay_estimation.hpp.
#include "magnetometer_insitu_calibration/estimation/delay_estimation.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "spectral_tools.hpp"

#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

namespace magnetometer_insitu_calibration {

void DelaySettings::validate() const {
  if (!(low_hz > 0.0) || !std::isfinite(low_hz)) throw InputError("delay_low_hz", "must be a positive frequency in Hz");
  if (!(high_hz > low_hz) || !std::isfinite(high_hz)) throw InputError("delay_max_hz", "must be finite and above the low edge");
  if (bin_harmonics < 2) throw InputError("delay_bin_harmonics", "must be >= 2");
  if (!(min_coherence > 0.0 && min_coherence < 1.0)) throw InputError("delay_min_coherence", "must be in (0, 1)");
}

namespace {

/// Hann taper 0.5 - 0.5 cos(2 pi (i + 1/2) / L), i = 0 .. L - 1, kept for the last length asked
/// on this thread (its cosines cost as much as a transform).
const std::vector<double>& hann_taper(std::size_t length) {
  thread_local std::vector<double> taper;
  if (taper.size() != length) {
    taper.resize(length);
    for (std::size_t i = 0; i < length; ++i) {
      taper[i] = 0.5 - 0.5 * std::cos(2.0 * M_PI * (static_cast<double>(i) + 0.5) / static_cast<double>(length));
    }
  }
  return taper;
}

}  // namespace

DelayEstimate estimate_delay(const Eigen::Ref<const Readings>& reference_nT, const Eigen::Ref<const Readings>& test_nT,
                             const Eigen::Matrix3d& n, double sample_period_s, const DelaySettings& settings) {
  settings.validate();
  if (reference_nT.rows() != test_nT.rows()) throw std::invalid_argument("estimate_delay: lengths differ");
  DelayEstimate out;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  out.delay_s = out.stderr_s = out.ci95_s = nan;
  if (!n.allFinite() || reference_nT.rows() < 64) {
    out.text = "no delay: matrix not finite or window too short";
    return out;
  }
  // Prediction P = R n and the test, first-differenced, detrended, Hann-tapered: the same linear
  // operations on both sides, so the phase between them is still -2 pi f tau.
  // The N - 1 differences are transformed zero-padded to the record's own length N: N - 1 is
  // seldom a fast FFT length (1 day at 1 Hz: 86399 is prime, 13x slower than 86400 with
  // FFTW_ESTIMATE), and one zero after a taper that is already ~0 at the ends only moves the
  // harmonics to j / (N dt).
  const std::size_t length = static_cast<std::size_t>(reference_nT.rows()) - 1;
  const std::size_t padded = length + 1;
  thread_local Readings predicted;  // R n, nT; kept per thread with the buffers below
  thread_local std::vector<Eigen::VectorXcd> spectra(6);
  thread_local std::vector<double> column;
  predicted.noalias() = reference_nT * n;
  detail::RealDft& dft = detail::thread_real_dft();
  const std::vector<double>& hann = hann_taper(length);
  column.resize(length);
  for (int c = 0; c < 6; ++c) {
    const int k = c % 3;
    for (std::size_t i = 0; i < length; ++i) {
      const Eigen::Index r = static_cast<Eigen::Index>(i);
      column[i] = c < 3 ? predicted(r + 1, k) - predicted(r, k) : test_nT(r + 1, k) - test_nT(r, k);
    }
    detail::detrend(column.data(), length);
    for (std::size_t i = 0; i < length; ++i) column[i] *= hann[i];
    dft.transform(column.data(), length, padded, spectra[static_cast<std::size_t>(c)]);
  }
  const double duration_s = static_cast<double>(padded) * sample_period_s;  // harmonic spacing 1 / duration
  const double nyquist = 0.5 / sample_period_s;
  const long j_low = std::max(2L, static_cast<long>(std::ceil(settings.low_hz * duration_s)));
  const long j_high = std::min(static_cast<long>(std::floor(std::min(settings.high_hz, 0.8 * nyquist) * duration_s)),
                               static_cast<long>(padded / 2) - 1);
  // Phase bins. The Hann taper correlates neighbouring harmonics: G harmonics carry about
  // G / 1.5 independent values (equivalent bandwidth of the Hann window, 1.5 bins).
  struct Bin {
    double f, phase, weight;
  };
  std::vector<Bin> bins;
  const long g = static_cast<long>(settings.bin_harmonics);
  for (long first = j_low; first + g - 1 <= j_high; first += g) {
    std::complex<double> cross = 0.0;
    double pp = 0.0, tt = 0.0, f_sum = 0.0;
    for (long j = first; j < first + g; ++j) {
      for (int k = 0; k < 3; ++k) {
        const std::complex<double> p = spectra[static_cast<std::size_t>(k)](j);
        const std::complex<double> t = spectra[static_cast<std::size_t>(k + 3)](j);
        cross += std::conj(p) * t;  // phase -2 pi f tau for every component alike
        pp += std::norm(p);
        tt += std::norm(t);
      }
      f_sum += static_cast<double>(j) / duration_s;
    }
    if (!(pp > 0.0 && tt > 0.0)) continue;
    const double coh = std::norm(cross) / (pp * tt);
    if (!(coh >= settings.min_coherence) || coh >= 1.0) continue;
    const double independent = 3.0 * static_cast<double>(g) / 1.5;  // three components
    const double var_phase = (1.0 - coh) / (2.0 * independent * coh);
    bins.push_back({f_sum / static_cast<double>(g), std::arg(cross), 1.0 / var_phase});
  }
  out.bins = bins.size();
  if (bins.size() < 3) {
    out.text = "no delay: fewer than 3 coherent phase bins";
    return out;
  }
  double swff = 0.0, swfp = 0.0;
  for (const Bin& b : bins) {
    const double w2pf = 2.0 * M_PI * b.f;
    swff += b.weight * w2pf * w2pf;
    swfp += b.weight * w2pf * b.phase;
  }
  const double tau = -swfp / swff;
  double chi2 = 0.0;
  for (const Bin& b : bins) {
    const double r = b.phase + 2.0 * M_PI * b.f * tau;
    chi2 += b.weight * r * r;
  }
  out.chi2_per_dof = chi2 / static_cast<double>(bins.size() - 1);
  out.delay_s = tau;
  out.stderr_s = std::sqrt(1.0 / swff) * std::sqrt(std::max(1.0, out.chi2_per_dof));
  out.ci95_s = 1.959964 * out.stderr_s;
  out.ok = std::isfinite(tau);
  std::ostringstream text;
  text << "delay " << tau * 1e3 << " +- " << out.ci95_s * 1e3 << " ms (95 %) from " << bins.size()
       << " phase bins, chi2/dof " << out.chi2_per_dof;
  out.text = text.str();
  return out;
}

}  // namespace magnetometer_insitu_calibration
