// Delay between the instruments from the cross-spectral phase: see delay_estimation.hpp.
#include "magnetometer_insitu_calibration/estimation/delay_estimation.hpp"

#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"  // kNormalQuantile95

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "delay_spectra.hpp"
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

DelayEstimate estimate_delay(const Eigen::Ref<const Readings>& reference_nT, const Eigen::Ref<const Readings>& test_nT,
                             const Eigen::Matrix3d& n, double sample_period_s, const DelaySettings& settings) {
  settings.validate();
  if (reference_nT.rows() != test_nT.rows()) throw std::invalid_argument("estimate_delay: lengths differ");
  // The six whole-window transforms of R and T (the robust estimator passes Eq. 2's instead).
  thread_local std::vector<Eigen::VectorXcd> spectra(6);
  thread_local Eigen::VectorXd values;  // one column, centred (nT)
  detail::WholeWindowSpectra whole;
  whole.length = static_cast<std::size_t>(reference_nT.rows());
  if (n.allFinite() && reference_nT.rows() >= 64) {
    detail::RealDft& dft = detail::thread_real_dft();
    for (int c = 0; c < 6; ++c) {
      const auto column = c < 3 ? reference_nT.col(c) : test_nT.col(c - 3);
      values = column;
      values.array() -= values.mean();  // only bin 0 changes; keeps rounding small
      dft.transform(values.data(), whole.length, spectra[static_cast<std::size_t>(c)]);
      whole.bins[static_cast<std::size_t>(c)] = spectra[static_cast<std::size_t>(c)].data();
      whole.ends[static_cast<std::size_t>(c)] = detail::column_ends(values);
    }
  }
  return detail::estimate_delay_from_spectra(whole, n, sample_period_s, settings);
}

DelayEstimate detail::estimate_delay_from_spectra(const WholeWindowSpectra& whole, const Eigen::Matrix3d& n,
                                                  double sample_period_s, const DelaySettings& settings) {
  settings.validate();
  DelayEstimate out;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  out.delay_s = out.stderr_s = out.ci95_s = nan;
  if (!n.allFinite() || whole.length < 64) {
    out.text = "no delay: matrix not finite or window too short";
    return out;
  }
  // Prediction P = R n and the test, first-differenced, detrended, Hann-tapered (delay_spectra.hpp):
  // the same linear operations on both sides, so the phase between them is still -2 pi f tau.
  // The N - 1 differences are padded with one zero to the record's own length N, the length of
  // the transforms they come from.
  const std::size_t padded = whole.length;
  const double duration_s = static_cast<double>(padded) * sample_period_s;  // harmonic spacing 1 / duration
  const double nyquist = 0.5 / sample_period_s;
  const long j_low = std::max(2L, static_cast<long>(std::ceil(settings.low_hz * duration_s)));
  const long j_high = std::min(static_cast<long>(std::floor(std::min(settings.high_hz, 0.8 * nyquist) * duration_s)),
                               static_cast<long>(padded / 2) - 1);
  if (j_high < j_low) {
    out.text = "no delay: fewer than 3 coherent phase bins";
    return out;
  }
  // Tapered spectra at j_low .. j_high: index j - j_low. P's bins are n's combinations of R's.
  const std::size_t count = static_cast<std::size_t>(j_high - j_low + 1);
  thread_local std::vector<std::complex<double>> spectra[6];
  thread_local std::vector<std::complex<double>> combined;
  combined.resize(count + 2);
  thread_local detail::DifferenceKernel kernel;
  kernel.prepare(padded, j_low, j_high);
  for (int k = 0; k < 3; ++k) {
    detail::ColumnEnds ends;
    for (std::size_t i = 0; i < count + 2; ++i) {
      const std::size_t j = static_cast<std::size_t>(j_low - 1) + i;
      combined[i] = n(0, k) * whole.bins[0][j] + n(1, k) * whole.bins[1][j] + n(2, k) * whole.bins[2][j];
    }
    for (int m = 0; m < 3; ++m) {
      ends.first += n(m, k) * whole.ends[static_cast<std::size_t>(m)].first;
      ends.last += n(m, k) * whole.ends[static_cast<std::size_t>(m)].last;
      ends.interior_sum += n(m, k) * whole.ends[static_cast<std::size_t>(m)].interior_sum;
    }
    spectra[k].resize(count);
    detail::tapered_difference_spectrum(combined.data(), ends, kernel, spectra[k].data());
    spectra[k + 3].resize(count);
    detail::tapered_difference_spectrum(whole.bins[static_cast<std::size_t>(k + 3)] + (j_low - 1),
                                        whole.ends[static_cast<std::size_t>(k + 3)], kernel, spectra[k + 3].data());
  }
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
        const std::complex<double> p = spectra[k][static_cast<std::size_t>(j - j_low)];
        const std::complex<double> t = spectra[k + 3][static_cast<std::size_t>(j - j_low)];
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
  out.ci95_s = kNormalQuantile95 * out.stderr_s;
  out.ok = std::isfinite(tau);
  std::ostringstream text;
  text << "delay " << tau * 1e3 << " +- " << out.ci95_s * 1e3 << " ms (95 %) from " << bins.size()
       << " phase bins, chi2/dof " << out.chi2_per_dof;
  out.text = text.str();
  return out;
}

}  // namespace magnetometer_insitu_calibration
