// The reference's noise from the pair above the band: see two_instrument_noise.hpp.
#include "magnetometer_insitu_calibration/estimation/two_instrument_noise.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/estimation/frequency_bins.hpp"
#include "spectral_tools.hpp"

#include <Eigen/LU>

#include <cmath>
#include <array>
#include <complex>

namespace magnetometer_insitu_calibration {

namespace {
constexpr double kHannSumInflation = 35.0 / 18.0;
}  // namespace

TwoInstrumentNoise two_instrument_noise(const Readings& reference, const Readings& test, double dt,
                                        const Eigen::Matrix3d& n, const RelativeTransfer& transfer, double low_hz,
                                        double high_hz, int bins) {
  if (reference.rows() != test.rows()) throw InputError("two_instrument_noise", "records of unequal length");
  if (!(dt > 0.0)) throw InputError("two_instrument_noise", "sample period must be > 0 s");
  if (!(low_hz > 0.0) || !(high_hz > low_hz) || !(high_hz <= 0.5 / dt) || bins < 1)
    throw InputError("two_instrument_noise", "needs 0 < low < high <= Nyquist and bins >= 1");
  if (!n.allFinite() || std::abs(n.determinant()) < 1e-6) throw InputError("two_instrument_noise", "n is singular");
  const std::size_t length = static_cast<std::size_t>(reference.rows());
  const double duration = static_cast<double>(length) * dt;
  // Hann taper after the detrend: mean(w^2) = 3/8 enters the PSD's scale.
  std::vector<double> taper(length), column(length);
  for (std::size_t i = 0; i < length; ++i) taper[i] = 0.5 - 0.5 * std::cos(2.0 * M_PI * (static_cast<double>(i) + 0.5) / static_cast<double>(length));
  std::array<Eigen::VectorXcd, 6> spectra;
  detail::RealDft& dft = detail::thread_real_dft();
  for (int c = 0; c < 6; ++c) {
    const Readings& from = c < 3 ? reference : test;
    for (std::size_t i = 0; i < length; ++i) column[i] = from(static_cast<Eigen::Index>(i), c % 3);
    detail::detrend(column.data(), length);
    for (std::size_t i = 0; i < length; ++i) column[i] *= taper[i];
    dft.transform(column.data(), length, spectra[static_cast<std::size_t>(c)]);
  }
  const Eigen::Matrix3d n_inverse = n.inverse();
  TwoInstrumentNoise out;
  const std::vector<double> edges = log_spaced_bin_edges(low_hz, high_hz, bins);
  const Eigen::Index harmonics = spectra[0].size();
  for (int k = 0; k < bins; ++k) {
    const double lo = edges[static_cast<std::size_t>(k)], hi = edges[static_cast<std::size_t>(k) + 1];
    // Per harmonic and axis, the reference's noise term z = Re(conj(R_c) (R - T diag(H)^-1 n^-1)_c):
    // its sum over the bin is diag(S_RR - S_RT diag(H)^-1 n^-1), the estimate (the field cancels),
    // its scatter the estimate's spread; |R_c|^2 - z is the field's part, diag(P).
    Eigen::Vector3d rr_sum = Eigen::Vector3d::Zero(), z_sum = Eigen::Vector3d::Zero(), z2_sum = Eigen::Vector3d::Zero();
    int count = 0;
    for (Eigen::Index j = 1; j < harmonics - 1; ++j) {
      const double f = static_cast<double>(j) / duration;
      if (f < lo || f >= hi) continue;
      ++count;
      Eigen::RowVector3cd r, t;
      for (int c = 0; c < 3; ++c) {
        r(c) = spectra[static_cast<std::size_t>(c)](j);
        // The test's spectrum with its response divided out: T diag(H)^-1.
        const std::complex<double> h = std::exp(std::complex<double>(0.0, -2.0 * M_PI * f * transfer.delay_s)) /
                                       std::complex<double>(1.0, std::isfinite(transfer.corner_hz(c)) ? f / transfer.corner_hz(c) : 0.0);
        t(c) = spectra[static_cast<std::size_t>(c + 3)](j) / h;
      }
      const Eigen::RowVector3cd u = r - t * n_inverse;
      for (int c = 0; c < 3; ++c) {
        const double z = (std::conj(r(c)) * u(c)).real();
        rr_sum(c) += std::norm(r(c));
        z_sum(c) += z;
        z2_sum(c) += z * z;
      }
    }
    if (count < 8) throw InputError("two_instrument_noise", "a frequency bin holds fewer than 8 harmonics: record too short");
    const double scale = 2.0 * dt / (static_cast<double>(length) * 0.375 * static_cast<double>(count));
    out.bin_low_hz.push_back(lo);
    out.bin_high_hz.push_back(hi);
    out.harmonics.push_back(count);
    out.coherent_psd.push_back((rr_sum - z_sum) * scale);
    out.reference_psd.push_back(z_sum * scale);
    // Var(sum z) = kHannSumInflation x the sum of squared deviations: Hann-tapered harmonics
    // j and j +- 1, j +- 2 correlate by -2/3 and 1/6 in amplitude, so their products z by 4/9
    // and 1/36 (1 + 2 (4/9 + 1/36) = 35/18) where the spectra are smooth over a few harmonics.
    const Eigen::Vector3d deviations = (z2_sum - z_sum.cwiseAbs2() / count).cwiseMax(0.0);
    out.reference_psd_sd.push_back((kHannSumInflation * deviations).cwiseSqrt() * scale);
  }
  return out;
}

}  // namespace magnetometer_insitu_calibration
