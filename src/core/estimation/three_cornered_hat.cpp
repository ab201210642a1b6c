// Three-cornered hat: see three_cornered_hat.hpp.
#include "magnetometer_insitu_calibration/estimation/three_cornered_hat.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "spectral_tools.hpp"

#include <cmath>
#include <vector>

namespace magnetometer_insitu_calibration {

namespace {

/// Mean one-sided periodogram (nT^2/Hz) per axis of T_test - T_ref n over each bin.
std::vector<Eigen::Vector3d> residual_psd(const Readings& ref, const Readings& test, double dt,
                                          const std::vector<double>& low, const std::vector<double>& high,
                                          detail::RealDft& dft) {
  EstimatorSettings es;
  es.band_low_hz = low.front();
  es.band_high_hz = high.back();
  FdWlseEstimator plain(es);
  const WindowEstimate e = plain.estimate(ref, test, dt);
  if (!e.n.allFinite()) throw InputError("three_cornered_hat", "Eq. 2 failed on a pair: " + e.quality_text);
  const Readings residual = test - ref * e.n;
  const std::size_t n = static_cast<std::size_t>(residual.rows());
  const double duration = static_cast<double>(n) * dt;
  std::vector<Eigen::Vector3d> psd(low.size(), Eigen::Vector3d::Zero());
  std::vector<int> count(low.size(), 0);
  std::vector<double> column(n);
  Eigen::VectorXcd spectrum;
  for (int c = 0; c < 3; ++c) {
    for (std::size_t i = 0; i < n; ++i) column[i] = residual(static_cast<Eigen::Index>(i), c);
    detail::detrend(column.data(), n);
    dft.transform(column.data(), n, spectrum);
    for (Eigen::Index j = 1; j < spectrum.size() - 1; ++j) {
      const double f = static_cast<double>(j) / duration;
      for (std::size_t k = 0; k < low.size(); ++k) {
        if (f < low[k] || f >= high[k]) continue;
        // E|X_j|^2 = N S(f) / (2 dt) for the unnormalised DFT (errors_in_variables.hpp).
        psd[k](c) += std::norm(spectrum(j)) * 2.0 * dt / static_cast<double>(n);
        if (c == 0) ++count[k];
      }
    }
  }
  for (std::size_t k = 0; k < low.size(); ++k) {
    if (count[k] == 0) throw InputError("three_cornered_hat", "a frequency bin holds no harmonic: record too short");
    psd[k] /= static_cast<double>(count[k]);
  }
  return psd;
}

}  // namespace

ThreeCorneredHatResult three_cornered_hat(const Readings& a, const Readings& b, const Readings& c, double dt,
                                          const ThreeCorneredHatSettings& s) {
  if (a.rows() != b.rows() || a.rows() != c.rows()) throw InputError("three_cornered_hat", "records of unequal length");
  if (a.rows() < 64) throw InputError("three_cornered_hat", "fewer than 64 samples");
  if (!(dt > 0.0)) throw InputError("three_cornered_hat", "sample period must be > 0 s");
  if (!(s.band_low_hz > 0.0) || !(s.band_high_hz > s.band_low_hz) || s.bins < 1)
    throw InputError("three_cornered_hat", "needs 0 < band_low_hz < band_high_hz and bins >= 1");
  ThreeCorneredHatResult out;
  const double ratio = std::pow(s.band_high_hz / s.band_low_hz, 1.0 / s.bins);
  for (int k = 0; k < s.bins; ++k) {
    out.bin_low_hz.push_back(s.band_low_hz * std::pow(ratio, k));
    out.bin_high_hz.push_back(k + 1 == s.bins ? s.band_high_hz : s.band_low_hz * std::pow(ratio, k + 1));
  }
  detail::RealDft dft;
  out.pair_psd_nT2_per_hz[0] = residual_psd(a, b, dt, out.bin_low_hz, out.bin_high_hz, dft);  // ab
  out.pair_psd_nT2_per_hz[1] = residual_psd(a, c, dt, out.bin_low_hz, out.bin_high_hz, dft);  // ac
  out.pair_psd_nT2_per_hz[2] = residual_psd(b, c, dt, out.bin_low_hz, out.bin_high_hz, dft);  // bc
  for (std::size_t k = 0; k < out.bin_low_hz.size(); ++k) {
    const Eigen::Vector3d ab = out.pair_psd_nT2_per_hz[0][k], ac = out.pair_psd_nT2_per_hz[1][k],
                          bc = out.pair_psd_nT2_per_hz[2][k];
    out.psd_nT2_per_hz[0].push_back(0.5 * (ab + ac - bc));
    out.psd_nT2_per_hz[1].push_back(0.5 * (ab + bc - ac));
    out.psd_nT2_per_hz[2].push_back(0.5 * (ac + bc - ab));
  }
  return out;
}

}  // namespace magnetometer_insitu_calibration
