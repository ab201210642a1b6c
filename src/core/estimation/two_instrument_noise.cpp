// The reference's noise from the pair above the band: see two_instrument_noise.hpp.
#include "magnetometer_insitu_calibration/estimation/two_instrument_noise.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/estimation/frequency_bins.hpp"
#include "spectral_tools.hpp"

#include <Eigen/LU>

#include <array>
#include <cmath>
#include <complex>
#include <cstdio>
#include <limits>

namespace magnetometer_insitu_calibration {

namespace {
constexpr double kHannSumInflation = 35.0 / 18.0;

void check_band(const PairSpectra& spectra, const Eigen::Matrix3d& n, double low_hz, double high_hz, int bins) {
  if (!(low_hz > 0.0) || !(high_hz > low_hz) || !(high_hz <= 0.5 / spectra.dt) || bins < 1)
    throw InputError("two_instrument_noise", "needs 0 < low < high <= Nyquist and bins >= 1");
  if (!n.allFinite() || std::abs(n.determinant()) < 1e-6) throw InputError("two_instrument_noise", "n is singular");
}
}  // namespace

PairSpectra pair_spectra(const Readings& reference, const Readings& test, double dt) {
  if (reference.rows() != test.rows()) throw InputError("two_instrument_noise", "records of unequal length");
  if (!(dt > 0.0)) throw InputError("two_instrument_noise", "sample period must be > 0 s");
  PairSpectra out;
  out.length = static_cast<std::size_t>(reference.rows());
  out.dt = dt;
  std::vector<double> taper(out.length), column(out.length);
  for (std::size_t i = 0; i < out.length; ++i)
    taper[i] = 0.5 - 0.5 * std::cos(2.0 * M_PI * (static_cast<double>(i) + 0.5) / static_cast<double>(out.length));
  detail::RealDft& dft = detail::thread_real_dft();
  for (int c = 0; c < 6; ++c) {
    const Readings& from = c < 3 ? reference : test;
    for (std::size_t i = 0; i < out.length; ++i) column[i] = from(static_cast<Eigen::Index>(i), c % 3);
    detail::detrend(column.data(), out.length);
    for (std::size_t i = 0; i < out.length; ++i) column[i] *= taper[i];
    dft.transform(column.data(), out.length, out.columns[static_cast<std::size_t>(c)]);
  }
  return out;
}

TwoInstrumentNoise two_instrument_noise(const Readings& reference, const Readings& test, double dt,
                                        const Eigen::Matrix3d& n, const RelativeTransfer& transfer, double low_hz,
                                        double high_hz, int bins) {
  return two_instrument_noise(pair_spectra(reference, test, dt), n, transfer, low_hz, high_hz, bins);
}

TwoInstrumentNoise two_instrument_noise(const PairSpectra& pair, const Eigen::Matrix3d& n,
                                        const RelativeTransfer& transfer, double low_hz, double high_hz, int bins) {
  check_band(pair, n, low_hz, high_hz, bins);
  const std::size_t length = pair.length;
  const double dt = pair.dt, duration = static_cast<double>(length) * dt;
  // Hann taper after the detrend: mean(w^2) = 3/8 enters the PSD's scale.
  const std::array<Eigen::VectorXcd, 6>& spectra = pair.columns;
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

bool PhaseTransferFit::any_corner() const {
  return transfer.corner_hz.array().isFinite().any();
}

namespace {

/// One bin's phase of C_k per test component: at its weighted mean frequency (Hz), with its
/// variance (rad^2; infinite where the bin has no coherent signal).
struct BinPhase {
  Eigen::Vector3d frequency_hz, phase_rad, variance;
};

BinPhase bin_phase(const std::array<Eigen::VectorXcd, 6>& spectra, const Eigen::Matrix3d& n, double duration_s,
                   double start_delay_s, double lo, double hi) {
  Eigen::Vector3cd cross = Eigen::Vector3cd::Zero();
  Eigen::Vector3d qq = Eigen::Vector3d::Zero(), tt = Eigen::Vector3d::Zero(), weight = Eigen::Vector3d::Zero(),
                  weighted_f = Eigen::Vector3d::Zero();
  int count = 0;
  for (Eigen::Index j = 1; j < spectra[0].size() - 1; ++j) {
    const double f = static_cast<double>(j) / duration_s;
    if (f < lo || f >= hi) continue;
    ++count;
    Eigen::RowVector3cd r;
    for (int c = 0; c < 3; ++c) r(c) = spectra[static_cast<std::size_t>(c)](j);
    const Eigen::RowVector3cd q = r * n;  // the test predicted from the reference
    const std::complex<double> derotate = std::exp(std::complex<double>(0.0, 2.0 * M_PI * f * start_delay_s));
    for (int k = 0; k < 3; ++k) {
      const std::complex<double> t = spectra[static_cast<std::size_t>(k + 3)](j);
      cross(k) += std::conj(q(k)) * t * derotate;
      qq(k) += std::norm(q(k));
      tt(k) += std::norm(t);
      const double w = std::abs(q(k)) * std::abs(t);
      weight(k) += w;
      weighted_f(k) += w * f;
    }
  }
  BinPhase out;
  const double independent = static_cast<double>(count) / kHannSumInflation;
  for (int k = 0; k < 3; ++k) {
    const double coherence = qq(k) > 0.0 && tt(k) > 0.0 ? std::norm(cross(k)) / (qq(k) * tt(k)) : 0.0;
    out.frequency_hz(k) = weight(k) > 0.0 ? weighted_f(k) / weight(k) : 0.5 * (lo + hi);
    out.phase_rad(k) = std::arg(cross(k));
    out.variance(k) = count >= 8 && coherence > 0.0 ? std::max(1.0 - coherence, 1e-12) / (2.0 * coherence * independent)
                                                    : std::numeric_limits<double>::infinity();
  }
  return out;
}

/// Weighted least squares of the bins' phases against -2 pi f d - atan(f q) at p = (d, q).
struct PhaseNormal {
  Eigen::Matrix2d matrix = Eigen::Matrix2d::Zero();
  Eigen::Vector2d gradient = Eigen::Vector2d::Zero();
  double chi2 = 0.0;
  int used = 0;
};

PhaseNormal phase_normal(const std::vector<BinPhase>& phases, const Eigen::Vector2d& p) {
  PhaseNormal out;
  for (const BinPhase& b : phases) {
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(b.variance(k))) continue;
      const double f = b.frequency_hz(k), w = 1.0 / b.variance(k);
      const double model = -2.0 * M_PI * f * p(0) - std::atan(f * p(1));
      // The measured phase taken to within pi of the model (a wrapped phase of a long delay).
      const double residual = std::remainder(b.phase_rad(k) - model, 2.0 * M_PI);
      const Eigen::Vector2d jacobian(-2.0 * M_PI * f, -f / (1.0 + f * f * p(1) * p(1)));
      out.matrix += w * jacobian * jacobian.transpose();
      out.gradient += w * jacobian * residual;
      out.chi2 += w * residual * residual;
      ++out.used;
    }
  }
  return out;
}

/// Levenberg-Marquardt on p = (d, q), q >= 0, from `p`. At q = 0 the columns of d and q are
/// proportional (atan(f q) ~ f q): only the curvature of atan tells them apart, so the caller
/// starts off q = 0 and the steps are damped. False when a step is not finite.
bool fit_delay_and_corner(const std::vector<BinPhase>& phases, Eigen::Vector2d& p, PhaseNormal& at) {
  at = phase_normal(phases, p);
  double damping = 1e-3;
  for (int iteration = 0; iteration < 100 && damping < 1e12; ++iteration) {
    Eigen::Matrix2d damped = at.matrix;
    damped.diagonal() *= 1.0 + damping;
    const Eigen::Vector2d step = damped.ldlt().solve(at.gradient);
    if (!step.allFinite()) return false;
    const Eigen::Vector2d next(p(0) + step(0), std::max(p(1) + step(1), 0.0));
    const PhaseNormal there = phase_normal(phases, next);
    if (there.chi2 <= at.chi2) {
      const bool converged = (next - p).cwiseAbs().maxCoeff() < 1e-7 || at.chi2 - there.chi2 < 1e-9 * at.chi2;
      p = next;
      at = there;
      damping = std::max(damping / 10.0, 1e-9);
      if (converged) break;
    } else {
      damping *= 10.0;
    }
  }
  return true;
}

}  // namespace

PhaseTransferFit fit_transfer_from_phase(const Readings& reference, const Readings& test, double dt,
                                         const Eigen::Matrix3d& n, double start_delay_s, double low_hz,
                                         double high_hz, int bins) {
  return fit_transfer_from_phase(pair_spectra(reference, test, dt), n, start_delay_s, low_hz, high_hz, bins);
}

PhaseTransferFit fit_transfer_from_phase(const PairSpectra& pair, const Eigen::Matrix3d& n, double start_delay_s,
                                         double low_hz, double high_hz, int bins) {
  check_band(pair, n, low_hz, high_hz, bins);
  PhaseTransferFit out;
  out.transfer.delay_s = start_delay_s;
  const double duration = static_cast<double>(pair.length) * pair.dt;
  const std::vector<double> edges = log_spaced_bin_edges(low_hz, high_hz, bins);
  std::vector<BinPhase> phases;
  for (int b = 0; b < bins; ++b) {
    phases.push_back(bin_phase(pair.columns, n, duration, start_delay_s, edges[static_cast<std::size_t>(b)],
                               edges[static_cast<std::size_t>(b) + 1]));
  }
  // From a corner at the bins' top, d holding the rest of its lag.
  const double start_q = 1.0 / high_hz;
  Eigen::Vector2d p(-start_q / (2.0 * M_PI), start_q);
  PhaseNormal at;
  if (phase_normal(phases, p).used < 4 || !fit_delay_and_corner(phases, p, at)) return out;
  const double dof = static_cast<double>(at.used - 2);
  out.chi2_per_dof = dof > 0.0 ? at.chi2 / dof : 0.0;
  out.fitted = true;
  out.inverse_corner_s = p(1);
  // At q = 0 the columns are proportional and the matrix singular: no standard error.
  const Eigen::Matrix2d covariance = at.matrix.inverse() * std::max(1.0, out.chi2_per_dof);
  out.inverse_corner_se_s = covariance.allFinite() && covariance(1, 1) >= 0.0 ? std::sqrt(covariance(1, 1))
                                                                             : std::numeric_limits<double>::infinity();
  // The delay alone (q = 0; linear in d, two steps for the wrapping) against the fit. Near q = 0
  // the corner's standard error says little (its column is the delay's there); the drop in chi^2
  // says how much curvature the phases show.
  Eigen::Vector2d delay_only = Eigen::Vector2d::Zero();
  for (int step = 0; step < 2; ++step) {
    const PhaseNormal at_delay = phase_normal(phases, delay_only);
    delay_only(0) += at_delay.gradient(0) / at_delay.matrix(0, 0);
  }
  out.curvature_chi2 = (phase_normal(phases, delay_only).chi2 - at.chi2) / std::max(1.0, out.chi2_per_dof);
  if (!(out.curvature_chi2 >= kPhaseCornerChi2) || !(p(1) > 0.0)) return out;
  out.transfer.corner_hz = Eigen::Vector3d::Constant(1.0 / p(1));
  out.transfer.delay_s = start_delay_s + p(0);
  char text[200];
  std::snprintf(text, sizeof text,
                "the test's roll-off from the phase above the band: corner %.3g Hz (1/fc %.3g +- %.2g s, chi2 drop %.1f), "
                "delay %.3g s",
                out.transfer.corner_hz(0), p(1), out.inverse_corner_se_s, out.curvature_chi2, out.transfer.delay_s);
  out.text = text;
  return out;
}

}  // namespace magnetometer_insitu_calibration
