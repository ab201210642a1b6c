// Automatic band from the coherence between the instruments: see band_selection.hpp.
#include "magnetometer_insitu_calibration/estimation/band_selection.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "spectral_tools.hpp"

#include <Eigen/LU>

#include <cmath>
#include <sstream>

namespace magnetometer_insitu_calibration {

void BandSelectionSettings::validate() const {
  if (!(search_low_hz > 0.0) || !std::isfinite(search_low_hz))
    throw InputError("band_search_low_hz", "must be a positive frequency in Hz");
  if (!(search_high_hz > search_low_hz) || !std::isfinite(search_high_hz))
    throw InputError("band_search_high_hz", "must be finite and above band_search_low_hz");
  if (!(min_coherence > 0.0 && min_coherence < 1.0)) throw InputError("min_band_coherence", "must be in (0, 1)");
  if (bins_per_decade < 1) throw InputError("bins_per_decade", "must be >= 1");
  if (min_bin_harmonics < 4) throw InputError("min_bin_harmonics", "must be >= 4 (three regressors)");
  if (min_band_harmonics < 5) throw InputError("min_band_harmonics", "must be >= 5");
}

BandSelection select_band(const Eigen::Ref<const Readings>& reference_nT, const Eigen::Ref<const Readings>& test_nT,
                          double sample_period_s, const BandSelectionSettings& settings) {
  settings.validate();
  if (reference_nT.rows() != test_nT.rows()) throw std::invalid_argument("select_band: lengths differ");
  const std::size_t length = static_cast<std::size_t>(reference_nT.rows());
  const double duration_s = static_cast<double>(length) * sample_period_s;
  BandSelection out;
  out.low_hz = settings.search_low_hz;
  out.high_hz = settings.search_high_hz;

  // Whole-window DFT of the six columns, detrended and Hann-tapered alike: the taper keeps the
  // strong low-frequency power of the field from leaking into the weak top of the band, where
  // the coherence would otherwise look better than it is.
  detail::RealDft& dft = detail::thread_real_dft();
  std::vector<Eigen::VectorXcd> spectra(6);
  std::vector<double> column(length);
  for (int c = 0; c < 6; ++c) {
    for (std::size_t i = 0; i < length; ++i) {
      column[i] = c < 3 ? reference_nT(static_cast<Eigen::Index>(i), c) : test_nT(static_cast<Eigen::Index>(i), c - 3);
    }
    detail::detrend(column.data(), length);
    for (std::size_t i = 0; i < length; ++i) {
      column[i] *= 0.5 - 0.5 * std::cos(2.0 * M_PI * (static_cast<double>(i) + 0.5) / static_cast<double>(length));
    }
    dft.transform(column.data(), length, spectra[static_cast<std::size_t>(c)]);
  }
  const long j_low = std::max(2L, static_cast<long>(std::ceil(settings.search_low_hz * duration_s - 1e-9)));
  const long j_high = std::min(static_cast<long>(std::floor(settings.search_high_hz * duration_s + 1e-9)),
                               static_cast<long>((length - 1) / 2));
  if (j_high - j_low + 1 < static_cast<long>(settings.min_band_harmonics)) {
    out.text = "window too short for the band search";
    return out;
  }
  // Log-spaced bin edges, each bin holding at least min_bin_harmonics harmonics.
  const double ratio = std::pow(10.0, 1.0 / settings.bins_per_decade);
  long first = j_low;
  while (first <= j_high) {
    long last = std::max(first + static_cast<long>(settings.min_bin_harmonics) - 1,
                         static_cast<long>(std::floor(static_cast<double>(first) * ratio)) - 1);
    if (last > j_high) last = j_high;
    if (j_high - last < static_cast<long>(settings.min_bin_harmonics)) last = j_high;  // no stub at the top
    Eigen::Matrix3cd srr = Eigen::Matrix3cd::Zero(), srt = Eigen::Matrix3cd::Zero();
    Eigen::Vector3d stt = Eigen::Vector3d::Zero();
    for (long j = first; j <= last; ++j) {
      Eigen::Vector3cd x, y;
      for (int k = 0; k < 3; ++k) {
        x(k) = spectra[static_cast<std::size_t>(k)](j);
        y(k) = spectra[static_cast<std::size_t>(k + 3)](j);
      }
      srr += x * x.adjoint();
      srt += x * y.adjoint();
      stt += y.cwiseAbs2();
    }
    CoherenceBin bin;
    bin.low_hz = static_cast<double>(first) / duration_s;
    bin.high_hz = static_cast<double>(last) / duration_s;
    bin.harmonics = static_cast<std::size_t>(last - first + 1);
    const Eigen::Matrix3cd srr_inv = srr.inverse();
    for (int l = 0; l < 3; ++l) {
      const std::complex<double> explained = (srt.col(l).adjoint() * srr_inv * srt.col(l))(0, 0);
      bin.coherence(l) = stt(l) > 0.0 ? std::clamp(explained.real() / stt(l), 0.0, 1.0) : 0.0;
    }
    out.bins.push_back(bin);
    first = last + 1;
  }
  // Widest contiguous run of bins whose every component reaches the threshold.
  std::size_t best_first = 0, best_count = 0, best_harmonics = 0;
  for (std::size_t b = 0; b < out.bins.size();) {
    if (out.bins[b].coherence.minCoeff() < settings.min_coherence) {
      ++b;
      continue;
    }
    std::size_t e = b, harmonics = 0;
    while (e < out.bins.size() && out.bins[e].coherence.minCoeff() >= settings.min_coherence) {
      harmonics += out.bins[e].harmonics;
      ++e;
    }
    if (harmonics > best_harmonics) {
      best_first = b;
      best_count = e - b;
      best_harmonics = harmonics;
    }
    b = e;
  }
  std::ostringstream text;
  if (best_count == 0 || best_harmonics < settings.min_band_harmonics) {
    text << "no band of " << settings.min_band_harmonics << "+ harmonics with coherence >= "
         << settings.min_coherence << " in " << settings.search_low_hz << "-" << settings.search_high_hz << " Hz";
    out.text = text.str();
    return out;
  }
  out.ok = true;
  out.low_hz = out.bins[best_first].low_hz;
  out.high_hz = out.bins[best_first + best_count - 1].high_hz;
  out.harmonics = best_harmonics;
  text << "band " << out.low_hz << "-" << out.high_hz << " Hz (" << best_harmonics
       << " harmonics) where every component's coherence >= " << settings.min_coherence;
  out.text = text.str();
  return out;
}

}  // namespace magnetometer_insitu_calibration
