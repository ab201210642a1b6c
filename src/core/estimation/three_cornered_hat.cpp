// Three-cornered hat: see three_cornered_hat.hpp.
#include "magnetometer_insitu_calibration/estimation/three_cornered_hat.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/estimation/frequency_bins.hpp"
#include "spectral_tools.hpp"

#include <Eigen/LU>

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <utility>
#include <vector>

namespace magnetometer_insitu_calibration {

namespace {

/// The harmonics j of [1, harmonics - 1) whose frequency j / duration_s lies in [low_hz, high_hz),
/// as [first, end): a contiguous run, found from the bin's edges instead of a scan of every
/// harmonic (the same set as the test f >= low && f < high on each j).
std::pair<Eigen::Index, Eigen::Index> bin_harmonics(double low_hz, double high_hz, double duration_s,
                                                    Eigen::Index harmonics) {
  const Eigen::Index last = harmonics - 1;  // exclusive
  const auto first_at_or_above = [&](double f_hz) {
    Eigen::Index j = std::clamp<Eigen::Index>(static_cast<Eigen::Index>(std::ceil(f_hz * duration_s)), 1, last);
    while (j > 1 && static_cast<double>(j - 1) / duration_s >= f_hz) --j;
    while (j < last && static_cast<double>(j) / duration_s < f_hz) ++j;
    return j;
  };
  const Eigen::Index first = first_at_or_above(low_hz);
  return {first, std::max(first, first_at_or_above(high_hz))};
}

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

/// Cross-spectral hat on the three records as given (each in its own frame). With the row
/// spectra A_j, B_j, C_j (1 x 3) of each harmonic and S_uv = sum over the bin of U_j^H V_j (3 x 3),
/// a = s + e_a, b = s G_b + e_b, c = s G_c + e_c give S_ab = P G_b, S_ac = P G_c,
/// S_bc = G_b^H P G_c, so the field's part of S_aa is P = S_ac S_bc^-1 S_ba and
///   N_a = diag(S_aa - S_ac S_bc^-1 S_ba),  N_b = diag(S_bb - S_bc S_ac^-1 S_ab),
///   N_c = diag(S_cc - S_cb S_ab^-1 S_ac):
/// any 3 x 3 gain and mixing between the records cancels, and the field to first order in the
/// noises, so no regression's attenuation or misalignment error is left in the estimate.
/// Averaged over count harmonics, divided by count - 3 (see below).
std::array<std::vector<Eigen::Vector3d>, 3> cross_spectral_psd(const std::array<const Readings*, 3>& records, double dt,
                                                               const std::vector<double>& low,
                                                               const std::vector<double>& high, detail::RealDft& dft,
                                                               std::array<std::vector<Eigen::Vector3d>, 3>& sd,
                                                               std::array<std::vector<Eigen::Vector3d>, 3>& floor) {
  const std::size_t n = static_cast<std::size_t>(records[0]->rows());
  const double duration = static_cast<double>(n) * dt;
  std::vector<double> column(n);
  std::array<std::array<Eigen::VectorXcd, 3>, 3> spectra;  // [record][axis]
  for (std::size_t r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      for (std::size_t i = 0; i < n; ++i) column[i] = (*records[r])(static_cast<Eigen::Index>(i), c);
      detail::detrend(column.data(), n);
      dft.transform(column.data(), n, spectra[r][static_cast<std::size_t>(c)]);
    }
  }
  std::array<std::vector<Eigen::Vector3d>, 3> out;
  const Eigen::Index harmonics = spectra[0][0].size();
  for (std::size_t k = 0; k < low.size(); ++k) {
    Eigen::Matrix3cd sum[3][3];
    for (auto& row : sum)
      for (auto& m : row) m.setZero();
    const std::pair<Eigen::Index, Eigen::Index> range = bin_harmonics(low[k], high[k], duration, harmonics);
    const Eigen::Index first = range.first, end = range.second;
    const int count = static_cast<int>(end - first);
    Eigen::Matrix3cd row_spectra;  // row r: record r's three axes at harmonic j
    for (Eigen::Index j = first; j < end; ++j) {
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) row_spectra(r, c) = spectra[static_cast<std::size_t>(r)][static_cast<std::size_t>(c)](j);
      for (int u = 0; u < 3; ++u)
        for (int v = u; v < 3; ++v) sum[u][v] += row_spectra.row(u).adjoint() * row_spectra.row(v);
    }
    if (count < 4) throw InputError("three_cornered_hat", "a frequency bin holds fewer than 4 harmonics: record too short");
    for (int u = 0; u < 3; ++u)
      for (int v = 0; v < u; ++v) sum[u][v] = sum[v][u].adjoint();
    // One-sided PSD. The field's part is fitted in 3 dimensions per harmonic set, which takes
    // 3 of the bin's `count` degrees of freedom from each noise (as a regression's residual
    // does): count - 3 (a level 3 % low over 0.0002-0.01 Hz in a day without it).
    const double scale = 2.0 * dt / (static_cast<double>(n) * static_cast<double>(count - 3));
    // N_x = diag(S_xx - S_xz S_yz^-1 S_yx). Its standard deviation: with W = S_xz S_yz^-1 fitted
    // on the same harmonics (the residual r = X - Y W^H is orthogonal to Z, as a regression's
    // residual is to its instrument), the estimate is sum conj(r) X = sum conj(r) (X - Z), so per
    // harmonic it holds conj(e_x - e_y') (e_x - e_z'), the others' noises through the fitted
    // matrices: for complex Gaussian noise the real part's variance is
    //   (N_x + N_y')(N_x + N_z') / 2 + N_x^2 / 2,
    // N_x + N_y' the mean |r|^2 and N_x + N_z' the mean |r'|^2 of r' = X - Z W'^H, W' = S_xy S_zy^-1;
    // over count - 3 independent harmonics (no taper). For the noisiest instrument this is about
    // N_x^2; for one much quieter than the other two it is N_y' N_z' / 2, which does not vanish
    // with N_x (N_x^2 + N_x N_d / 2 would state zero wherever a quiet instrument's estimate
    // came out negative).
    const auto residual_power = [&](int x, int y, const Eigen::Matrix3cd& w_adjoint) -> Eigen::Vector3d {
      Eigen::Vector3d r2_sum = Eigen::Vector3d::Zero();
      for (Eigen::Index j = first; j < end; ++j) {
        Eigen::RowVector3cd xr, yr;
        for (int c = 0; c < 3; ++c) {
          xr(c) = spectra[static_cast<std::size_t>(x)][static_cast<std::size_t>(c)](j);
          yr(c) = spectra[static_cast<std::size_t>(y)][static_cast<std::size_t>(c)](j);
        }
        r2_sum += (xr - yr * w_adjoint).cwiseAbs2().transpose();
      }
      return r2_sum;
    };
    const auto noise = [&](int x, int y, int z) -> Eigen::Vector3d {
      const Eigen::FullPivLU<Eigen::Matrix3cd> lu(sum[y][z]);
      const Eigen::Matrix3cd field = sum[x][z] * lu.solve(sum[y][x]);
      const Eigen::Matrix3cd w_adjoint = (sum[x][z] * lu.inverse()).adjoint();
      const Eigen::Matrix3cd w2_adjoint = (sum[x][y] * Eigen::FullPivLU<Eigen::Matrix3cd>(sum[z][y]).inverse()).adjoint();
      const double dof = static_cast<double>(count - 3);
      const Eigen::Vector3d n_x = ((sum[x][x] - field).diagonal().real() / dof).cwiseMax(0.0);  // per harmonic
      const Eigen::Vector3d m_y = residual_power(x, y, w_adjoint) / dof, m_z = residual_power(x, z, w2_adjoint) / dof;
      const Eigen::Vector3d variance = 0.5 * m_y.cwiseProduct(m_z) + 0.5 * n_x.cwiseAbs2();
      const Eigen::Vector3d others_y = (m_y - n_x).cwiseMax(0.0), others_z = (m_z - n_x).cwiseMax(0.0);
      floor[static_cast<std::size_t>(x)].push_back((0.5 * others_y.cwiseProduct(others_z)).cwiseSqrt() * (scale * dof));
      sd[static_cast<std::size_t>(x)].push_back((variance / dof).cwiseSqrt() * (scale * dof));
      return (sum[x][x] - field).diagonal().real() * scale;
    };
    out[0].push_back(noise(0, 1, 2));
    out[1].push_back(noise(1, 0, 2));
    out[2].push_back(noise(2, 0, 1));
  }
  return out;
}

}  // namespace

ThreeCorneredHatResult three_cornered_hat(const Readings& a, const Readings& b, const Readings& c, double dt,
                                          const ThreeCorneredHatSettings& s) {
  if (a.rows() != b.rows() || a.rows() != c.rows()) throw InputError("three_cornered_hat", "records of unequal length");
  if (a.rows() < 64) throw InputError("three_cornered_hat", "fewer than 64 samples");
  if (!(dt > 0.0)) throw InputError("three_cornered_hat", "sample period must be > 0 s");
  ThreeCorneredHatResult out;
  if (!s.bin_edges_hz.empty()) {
    const std::vector<double>& e = s.bin_edges_hz;
    bool ascending = e.size() >= 2 && e.front() > 0.0;
    for (std::size_t k = 1; k < e.size(); ++k) ascending = ascending && e[k] > e[k - 1];
    if (!ascending) throw InputError("three_cornered_hat", "bin_edges_hz must hold at least 2 positive, strictly ascending edges");
  } else {
    if (!(s.band_low_hz > 0.0) || !(s.band_high_hz > s.band_low_hz) || s.bins < 1)
      throw InputError("three_cornered_hat", "needs 0 < band_low_hz < band_high_hz and bins >= 1");
  }
  const std::vector<double> edges =
      s.bin_edges_hz.empty() ? log_spaced_bin_edges(s.band_low_hz, s.band_high_hz, s.bins) : s.bin_edges_hz;
  out.bin_low_hz.assign(edges.begin(), edges.end() - 1);
  out.bin_high_hz.assign(edges.begin() + 1, edges.end());
  detail::RealDft dft;
  if (s.method == ThreeCorneredHatMethod::kCrossSpectral) {
    out.psd_nT2_per_hz = cross_spectral_psd({&a, &b, &c}, dt, out.bin_low_hz, out.bin_high_hz, dft, out.psd_sd_nT2_per_hz,
                                           out.psd_floor_nT2_per_hz);
    return out;
  }
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
