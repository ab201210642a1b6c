// Robust frequency-domain estimator and the per-window dispatcher: see robust_estimator.hpp.
#include "magnetometer_insitu_calibration/estimation/robust_estimator.hpp"

#include "magnetometer_insitu_calibration/estimation/errors_in_variables.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "failed_window_estimate.hpp"
#include "spectral_tools.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numeric>
#include <sstream>

namespace magnetometer_insitu_calibration {

// ---------------------------------------------------------------------------------------------
// Names and validation of the settings declared in fd_wlse.hpp.

const char* estimator_method_name(EstimatorMethod method) {
  return method == EstimatorMethod::kPlain ? "plain" : "robust";
}

EstimatorMethod parse_estimator_method(const std::string& text, const std::string& where) {
  if (text == "plain") return EstimatorMethod::kPlain;
  if (text == "robust") return EstimatorMethod::kRobust;
  throw InputError(where, "expected plain or robust, got '" + text + "'");
}

const char* eiv_correction_name(EivCorrection mode) {
  switch (mode) {
    case EivCorrection::kNone: return "none";
    case EivCorrection::kNoiseRatio: return "ratio";
    case EivCorrection::kGiven: return "given";
  }
  return "unknown";
}

EivCorrection parse_eiv_correction(const std::string& text, const std::string& where) {
  if (text == "none") return EivCorrection::kNone;
  if (text == "ratio") return EivCorrection::kNoiseRatio;
  if (text == "given") return EivCorrection::kGiven;
  throw InputError(where, "expected none, ratio or given, got '" + text + "'");
}

void RobustSettings::validate() const {
  auto positive = [](double v) { return v > 0.0 && std::isfinite(v); };
  if (!positive(screen_threshold)) throw InputError("screen_threshold", "must be a positive number of sigmas");
  if (!positive(screen_baseline_s)) throw InputError("screen_baseline_s", "must be a positive time in s");
  if (!(screen_margin_s >= 0.0) || !std::isfinite(screen_margin_s))
    throw InputError("screen_margin_s", "must be a time >= 0 s");
  if (!positive(section_s)) throw InputError("section_s", "must be a positive time in s");
  if (!positive(huber_k)) throw InputError("huber_k", "must be positive (sigma units)");
  if (!(section_rejection > 2.0) || !std::isfinite(section_rejection))
    throw InputError("section_rejection", "must be finite and above 2");
  if (iterations < 1 || iterations > 100) throw InputError("iterations", "must be in [1, 100]");
  BandSelectionSettings band;
  band.search_low_hz = band_search_low_hz;
  band.search_high_hz = band_search_high_hz;
  band.min_coherence = min_band_coherence;
  band.validate();
  if (!positive(delay_max_hz)) throw InputError("delay_max_hz", "must be a positive frequency in Hz");
  if (!(eiv_noise_ratio >= 0.0) || !std::isfinite(eiv_noise_ratio))
    throw InputError("eiv_noise_ratio", "must be a finite ratio >= 0");
  if (!reference_white_nT.allFinite() || (reference_white_nT.array() < 0.0).any())
    throw InputError("reference_white_nT", "must be finite and >= 0");
  if (!reference_pink_nT_per_sqrt_hz.allFinite() || (reference_pink_nT_per_sqrt_hz.array() < 0.0).any())
    throw InputError("reference_pink_nT_per_sqrt_hz", "must be finite and >= 0");
}

// ---------------------------------------------------------------------------------------------

namespace {

constexpr double kSecondsPerDay = 86400.0;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kLn2 = 0.69314718055994531;
constexpr double kCellRejection = 5.0;  // sigmas (d) beyond which a cell gets weight 0
constexpr double kLevelCap = 25.0;      // cap of a cell's d^2 in its section's level
// Errors in variables, ratio mode: a cell's residual power |e_l|^2 enters the reference-noise
// estimate capped at kNoiseCap times its bin's robust scale and divided by
// E[min(X, c)] = 1 - e^-c (X ~ Exp(1), the law of |e|^2 / sigma^2 for Gaussian noise), so that
// the capped sum is unbiased on clean cells and an outlier adds at most c times its share.
// c = 9, not lower: inside a low-frequency bin the noise PSD (1/f) varies by up to 2x, and a
// cell whose mean is r times the bin's scale keeps 1 - e^{-c/r} of it under the cap (r = 1.5:
// 93 % for c = 4, 99.75 % for c = 9), so a low cap under-estimates N (measured 1-2 % low).
constexpr double kNoiseCap = 9.0;
// Fewest weighted sections for which the jackknife enters the covariance (step 6c).
constexpr std::size_t kMinJackknifeSections = 6;

/// Running-median baseline of x (one column), evaluated at block centres every `step` samples
/// over `window` samples and interpolated linearly: O(N window / step).
Eigen::VectorXd running_median_baseline(const Eigen::VectorXd& x, std::size_t window, std::size_t step) {
  const std::size_t n = static_cast<std::size_t>(x.size());
  Eigen::VectorXd base(x.size());
  if (n == 0) return base;
  window = std::min(window, n);
  std::vector<double> centres, values, buffer;
  for (std::size_t c = 0;; c += step) {
    const std::size_t centre = std::min(c, n - 1);
    const std::size_t first = centre >= window / 2 ? centre - window / 2 : 0;
    const std::size_t last = std::min(n, first + window);
    buffer.assign(x.data() + first, x.data() + last);
    centres.push_back(static_cast<double>(centre));
    values.push_back(detail::median(buffer));
    if (centre == n - 1) break;
  }
  std::size_t k = 0;
  for (std::size_t i = 0; i < n; ++i) {
    while (k + 1 < centres.size() && centres[k + 1] < static_cast<double>(i)) ++k;
    if (k + 1 >= centres.size()) {
      base(static_cast<Eigen::Index>(i)) = values.back();
      continue;
    }
    const double a = (static_cast<double>(i) - centres[k]) / (centres[k + 1] - centres[k]);
    base(static_cast<Eigen::Index>(i)) = values[k] + std::clamp(a, 0.0, 1.0) * (values[k + 1] - values[k]);
  }
  return base;
}

/// One harmonic of one section.
struct Cell {
  int section = 0;
  int bin = 0;           ///< scale bin (neighbouring frequencies)
  double frequency_hz = 0.0;
  double g = 0.0;        ///< lambda^gamma
  std::size_t length = 0;  ///< section length, samples
  Eigen::Vector3cd x, y;
};

/// n from the weighted sums (solve_weighted, solve_frozen): Eq. 2, n = A^-1 C, or, where the
/// reference noise N (nT^2) has power, corrected for it: n = (A - N)^-1 C. ok is false when A
/// is singular; without N, or when A - N is singular, eiv_applied is false and n, a_inverse
/// are Eq. 2's.
struct WeightedSolution {
  bool ok = false;
  bool eiv_applied = false;
  Eigen::Matrix3d n_uncorrected = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d n = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();                      ///< weighted, uncorrected
  Eigen::Matrix3d a_inverse_uncorrected = Eigen::Matrix3d::Zero();  ///< of A
  Eigen::Matrix3d a_inverse = Eigen::Matrix3d::Zero();              ///< of the (corrected) A
  Eigen::Matrix3d noise = Eigen::Matrix3d::Zero();                  ///< N applied, zero if none
};

/// The IRLS: the solution with its last weights, and those weights.
struct IrlsResult : WeightedSolution {
  std::vector<double> weight;          ///< per cell (cell x section)
  std::vector<double> section_weight;
  std::vector<Eigen::Vector3d> scale2; ///< per bin, sigma_l^2
  int iterations = 0;
};

/// Ratio mode: E|X_noise,c|^2 of the reference at cell c, estimated from the cell's own residual
/// power (share x capped |e|^2, see kNoiseCap). Per cell rather than one level per bin: the
/// noise PSD changes inside a bin (1/f) while the weights g = lambda^gamma rise across it, so a
/// bin-constant level misweights it; and the capped mean has half the variance of the median
/// (relative variance 1/n against 1/(n ln^2 2) = 2.08/n for exponential |e|^2), which matters
/// because (A - N)^-1 is convex in N: a noisier N is a biased (over-) correction.
Eigen::Vector3d ratio_noise_power(const Eigen::Vector3d& e2, const Eigen::Vector3d& scale2, double share) {
  static const double kappa = 1.0 - std::exp(-kNoiseCap);
  return (share / kappa) * e2.cwiseMin(kNoiseCap * scale2);
}

/// Weighted sums of Eq. 2 over the cells (cell weight w times lambda^gamma g; cells of weight 0
/// and of section `exclude` left out, -1 for none): A = sum w g Re(x x^H) and
/// C = sum w g Re(x y^H) (nT^2), and in given mode the reference's expected noise periodogram
/// N = sum w g E|X_noise|^2 (nT^2, diagonal; zero in the other modes).
struct NormalEquations {
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d given_noise = Eigen::Matrix3d::Zero();
};

NormalEquations weighted_normal_equations(const std::vector<Cell>& cells, const std::vector<double>& weight,
                                          const RobustSettings& rs, double sample_period_s, int exclude) {
  NormalEquations out;
  NoiseSpectrum given;
  given.white_nT = rs.reference_white_nT;
  given.pink_nT_per_sqrt_hz = rs.reference_pink_nT_per_sqrt_hz;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const Cell& cell = cells[i];
    const double wg = weight[i] * cell.g;
    if (wg == 0.0 || cell.section == exclude) continue;
    out.a.noalias() += wg * (cell.x * cell.x.adjoint()).real();
    out.c.noalias() += wg * (cell.x * cell.y.adjoint()).real();
    if (rs.eiv == EivCorrection::kGiven) {
      out.given_noise.diagonal() += wg * given.expected_periodogram(cell.frequency_hz, sample_period_s, cell.length);
    }
  }
  return out;
}

/// n = (A - N)^-1 C from the weighted sums and the inverse of A - N (N = 0: Eq. 2 itself, n in
/// test nT per reference nT); false when A - N is singular (errors_in_variables.hpp).
bool solve_corrected(const NormalEquations& sums, const Eigen::Matrix3d& noise, Eigen::Matrix3d& n,
                     Eigen::Matrix3d& a_inverse) {
  Eigen::MatrixXd solution, inverse;
  const Eigen::MatrixXd a_dyn = sums.a, c_dyn = sums.c;
  if (!corrected_solve(a_dyn, noise, c_dyn, solution, &inverse)) return false;
  n = solution;
  a_inverse = inverse;
  return true;
}

WeightedSolution solve_weighted(const NormalEquations& sums, const Eigen::Matrix3d& noise) {
  WeightedSolution out;
  if (!solve_corrected(sums, Eigen::Matrix3d::Zero(), out.n_uncorrected, out.a_inverse_uncorrected)) return out;
  out.ok = true;
  out.a = sums.a;
  out.n = out.n_uncorrected;
  out.a_inverse = out.a_inverse_uncorrected;
  Eigen::Matrix3d corrected, corrected_inverse;
  if (noise.diagonal().sum() > 0.0 && solve_corrected(sums, noise, corrected, corrected_inverse)) {
    out.n = corrected;
    out.a_inverse = corrected_inverse;
    out.noise = noise;
    out.eiv_applied = true;
  }
  return out;
}

/// n for frozen cell weights: the last step of the IRLS, and each delete-one-section refit of
/// the jackknife (exclude = that section; -1 for none). Ratio mode iterates the fixed point
/// n = (A - N(n))^-1 C, N(n) = sum w g ratio_noise_power(|e(n)|^2), to convergence from
/// n_start; given mode subtracts its known N; none solves Eq. 2 with the weights.
WeightedSolution solve_frozen(const std::vector<Cell>& cells, const std::vector<double>& weight,
                              const std::vector<Eigen::Vector3d>& scale2, const RobustSettings& rs,
                              double sample_period_s, int exclude, const Eigen::Matrix3d& n_start) {
  const double share = reference_share_of_residual(rs.eiv_noise_ratio);
  const NormalEquations sums = weighted_normal_equations(cells, weight, rs, sample_period_s, exclude);
  // None and given mode are one solve; ratio mode starts from Eq. 2's n (N = 0 here).
  WeightedSolution out = solve_weighted(sums, sums.given_noise);
  if (!out.ok || rs.eiv != EivCorrection::kNoiseRatio) return out;
  Eigen::Matrix3d n = n_start.allFinite() ? n_start : out.n_uncorrected;
  for (int it = 0; it < 100; ++it) {
    Eigen::Matrix3d noise = Eigen::Matrix3d::Zero();
    for (std::size_t i = 0; i < cells.size(); ++i) {
      const Cell& cell = cells[i];
      const double wg = weight[i] * cell.g;
      if (wg == 0.0 || cell.section == exclude) continue;
      const Eigen::Vector3d e2 = (cell.y - n.transpose() * cell.x).cwiseAbs2();
      noise.diagonal() += wg * ratio_noise_power(e2, scale2[static_cast<std::size_t>(cell.bin)], share);
    }
    Eigen::Matrix3d corrected, corrected_inverse;
    if (!(noise.diagonal().sum() > 0.0) || !solve_corrected(sums, noise, corrected, corrected_inverse)) {
      out.n = out.n_uncorrected;
      out.a_inverse = out.a_inverse_uncorrected;
      out.noise.setZero();
      out.eiv_applied = false;
      return out;
    }
    const bool converged = (corrected - n).cwiseAbs().maxCoeff() < 1e-12;
    n = corrected;
    out.n = n;
    out.a_inverse = corrected_inverse;
    out.noise = noise;
    out.eiv_applied = true;
    if (converged) break;
  }
  return out;
}

}  // namespace

struct RobustFdEstimator::Impl {
  detail::RealDft dft;
};

RobustFdEstimator::RobustFdEstimator(EstimatorSettings settings)
    : settings_(std::move(settings)), impl_(std::make_unique<Impl>()) {
  settings_.validate();
}

RobustFdEstimator::~RobustFdEstimator() = default;

std::vector<char> screen_residual(const Eigen::Ref<const Readings>& reference_nT, const Eigen::Ref<const Readings>& test_nT,
                                  const Eigen::Matrix3d& n, double sample_period_s, const RobustSettings& settings) {
  const std::size_t length = static_cast<std::size_t>(reference_nT.rows());
  std::vector<char> mask(length, 0);
  if (length < 16 || !n.allFinite()) return mask;
  const Readings residual = test_nT - reference_nT * n;
  const std::size_t window = std::max<std::size_t>(3, static_cast<std::size_t>(std::llround(settings.screen_baseline_s / sample_period_s)));
  const std::size_t step = std::max<std::size_t>(1, window / 10);
  const std::size_t margin = static_cast<std::size_t>(std::llround(settings.screen_margin_s / sample_period_s));
  std::vector<char> flag(length, 0);
  for (int c = 0; c < 3; ++c) {
    const Eigen::VectorXd e = residual.col(c);
    const Eigen::VectorXd hp = e - running_median_baseline(e, window, step);
    std::vector<double> abs_dev(length);
    const double centre = detail::median(std::vector<double>(hp.data(), hp.data() + length));
    for (std::size_t i = 0; i < length; ++i) abs_dev[i] = std::abs(hp(static_cast<Eigen::Index>(i)) - centre);
    const double sigma = 1.4826 * detail::median(abs_dev);
    if (!(sigma > 0.0)) continue;
    for (std::size_t i = 0; i < length; ++i) flag[i] |= abs_dev[i] > settings.screen_threshold * sigma;
  }
  // Widen each flagged sample by the margin (a transient's tails are below the threshold).
  long last_flag = -1;
  for (std::size_t i = 0; i < length; ++i) {
    if (flag[i]) last_flag = static_cast<long>(i);
    if (last_flag >= 0 && static_cast<long>(i) - last_flag <= static_cast<long>(margin)) mask[i] = 1;
  }
  last_flag = -1;
  for (std::size_t i = length; i-- > 0;) {
    if (flag[i]) last_flag = static_cast<long>(i);
    if (last_flag >= 0 && last_flag - static_cast<long>(i) <= static_cast<long>(margin)) mask[i] = 1;
  }
  return mask;
}

namespace {

/// Steps 3 and 5: IRLS over the cells.
IrlsResult irls(const std::vector<Cell>& cells, std::size_t sections, std::size_t bins, const RobustSettings& rs,
                double sample_period_s) {
  IrlsResult out;
  const std::size_t m = cells.size();
  out.weight.assign(m, 1.0);
  out.section_weight.assign(sections, 1.0);
  out.scale2.assign(bins, Eigen::Vector3d::Ones());
  std::vector<double> cell_weight(m, 1.0);
  const double share = reference_share_of_residual(rs.eiv_noise_ratio);
  bool have_scale = false;
  Eigen::Matrix3d n_previous = Eigen::Matrix3d::Constant(kNaN);
  std::vector<double> r2(m, 0.0);
  std::vector<Eigen::Vector3d> noise_power(m, Eigen::Vector3d::Zero());  // ratio mode, per cell
  for (int it = 0; it < rs.iterations; ++it) {
    const NormalEquations sums = weighted_normal_equations(cells, out.weight, rs, sample_period_s, -1);
    Eigen::Matrix3d noise = sums.given_noise;  // given mode; zero otherwise
    if (rs.eiv == EivCorrection::kNoiseRatio && have_scale) {
      for (std::size_t i = 0; i < m; ++i) {
        const double wg = out.weight[i] * cells[i].g;
        if (wg == 0.0) continue;
        noise.diagonal() += wg * noise_power[i];
      }
    }
    // N is zero in none mode (and in ratio mode before the first scale): Eq. 2 with the weights.
    const WeightedSolution solved = solve_weighted(sums, noise);
    if (!solved.ok) return out;
    static_cast<WeightedSolution&>(out) = solved;  // n, A and the correction; the weights stay
    out.iterations = it + 1;
    // Residuals, frequency-resolved robust scale, new weights.
    std::vector<std::vector<double>> per_bin(bins * 3);
    std::vector<Eigen::Vector3d> e2(m);
    for (std::size_t i = 0; i < m; ++i) {
      const Eigen::Vector3cd e = cells[i].y - out.n.transpose() * cells[i].x;
      e2[i] = e.cwiseAbs2();
      for (int l = 0; l < 3; ++l) per_bin[static_cast<std::size_t>(cells[i].bin) * 3 + static_cast<std::size_t>(l)].push_back(e2[i](l));
    }
    for (std::size_t b = 0; b < bins; ++b) {
      for (int l = 0; l < 3; ++l) {
        const double med = detail::median(per_bin[b * 3 + static_cast<std::size_t>(l)]);
        out.scale2[b](l) = std::max(med / kLn2, std::numeric_limits<double>::min());
      }
    }
    have_scale = true;
    for (std::size_t i = 0; i < m; ++i) {
      noise_power[i] = ratio_noise_power(e2[i], out.scale2[static_cast<std::size_t>(cells[i].bin)], share);
    }
    std::vector<std::vector<double>> section_r2(sections);
    for (std::size_t i = 0; i < m; ++i) {
      r2[i] = e2[i].cwiseQuotient(out.scale2[static_cast<std::size_t>(cells[i].bin)]).sum();
      const double d = std::sqrt(r2[i] / 3.0);
      // Huber; after two iterations (scale and n settled) cells beyond cell_rejection sigmas
      // are dropped: a clean cell has d^2 ~ Gamma(3)/3, P(d > 5) ~ 1e-14.
      cell_weight[i] = d <= rs.huber_k ? 1.0 : rs.huber_k / d;
      if (it >= 2 && d > kCellRejection) cell_weight[i] = 0.0;
      section_r2[static_cast<std::size_t>(cells[i].section)].push_back(std::min(r2[i] / 3.0, kLevelCap));
    }
    // Section level: mean of the capped d^2 of its cells (1 for a clean section, +-0.1 for 100
    // cells). The cap keeps one wild cell from rejecting a section; a step or a parked vehicle
    // (residual raised over many cells) lifts the mean well above the other sections'.
    std::vector<double> level(sections, kNaN), finite_levels;
    for (std::size_t s = 0; s < sections; ++s) {
      if (section_r2[s].empty()) continue;
      double sum = 0.0;
      for (double v : section_r2[s]) sum += v;
      level[s] = sum / static_cast<double>(section_r2[s].size());
      finite_levels.push_back(level[s]);
    }
    const double typical = std::max(1.0, detail::median(finite_levels));
    for (std::size_t s = 0; s < sections; ++s) {
      const double q = std::isfinite(level[s]) ? level[s] / typical : 1.0;
      out.section_weight[s] = q <= 2.0 ? 1.0 : (q <= rs.section_rejection ? 2.0 / q : 0.0);
    }
    for (std::size_t i = 0; i < m; ++i) {
      out.weight[i] = cell_weight[i] * out.section_weight[static_cast<std::size_t>(cells[i].section)];
    }
    const bool converged = n_previous.allFinite() && (out.n - n_previous).cwiseAbs().maxCoeff() < 1e-11;
    n_previous = out.n;
    if (converged && (rs.eiv != EivCorrection::kNoiseRatio || it > 0)) break;
  }
  return out;
}

/// Delete-one-section jackknife of row-major vec(n) (step 6b).
struct JackknifeResult {
  Matrix9d covariance = Matrix9d::Constant(kNaN);
  std::size_t sections = 0;  ///< sections that carried weight (the jackknife's groups)
};

JackknifeResult section_jackknife(const std::vector<Cell>& cells, const IrlsResult& fit, std::size_t k_sections,
                                  const RobustSettings& rs, double sample_period_s) {
  JackknifeResult out;
  std::vector<double> section_weight(k_sections, 0.0);
  for (std::size_t i = 0; i < cells.size(); ++i) section_weight[static_cast<std::size_t>(cells[i].section)] += fit.weight[i];
  std::vector<Eigen::Matrix<double, 9, 1>> leave_out;
  for (std::size_t s = 0; s < k_sections; ++s) {
    if (!(section_weight[s] > 0.0)) continue;  // a rejected section: deleting it changes nothing
    const WeightedSolution f = solve_frozen(cells, fit.weight, fit.scale2, rs, sample_period_s, static_cast<int>(s), fit.n);
    if (!f.ok) return out;  // one section held the whole signal of a direction: no jackknife
    Eigen::Matrix<double, 9, 1> v;
    for (int k = 0; k < 9; ++k) v(k) = f.n(k / 3, k % 3);
    leave_out.push_back(v);
  }
  out.sections = leave_out.size();
  if (out.sections < 2) return out;
  Eigen::Matrix<double, 9, 1> mean = Eigen::Matrix<double, 9, 1>::Zero();
  for (const auto& v : leave_out) mean += v;
  mean /= static_cast<double>(out.sections);
  out.covariance.setZero();
  for (const auto& v : leave_out) out.covariance.noalias() += (v - mean) * (v - mean).transpose();
  out.covariance *= static_cast<double>(out.sections - 1) / static_cast<double>(out.sections);
  return out;
}

/// Step 6c: the reported covariance. Per entry k of vec(n), the sandwich's variance is raised to
/// the jackknife's when that is larger, the whole row and column scaled so that the sandwich's
/// correlations are kept: Cov = D S D, D_kk = sqrt(max(1, J_kk / S_kk)).
///  - The sandwich S treats every cell (harmonic x section) as independent with fixed weights.
///    On disturbed records that is optimistic: a transient that survives the screen, a tilt or
///    a step is coherent over the harmonics of its section, the weights were chosen from the
///    same residuals, and in ratio mode the estimated noise level moves n; none of this is in
///    sum s_c s_c^T. Measured: S covers 84.7 % on the disturbed Monte Carlo (README).
///  - The delete-one-section jackknife J refits n without each section (same weights, the EIV
///    fixed point re-solved), so it sees every one of these effects as section-to-section
///    scatter, including the uncertainty of the EIV correction; sections are 3 h, much longer
///    than the residual's correlation, so they are nearly independent groups.
///  - J has only K - 1 degrees of freedom (7 for one day). Taking the larger of S and J per
///    entry keeps S as the floor where J comes out small by chance, which is what a Student-t
///    width would otherwise pay for; scaling J by (t_{K-1} / 1.96)^2 as well was measured and
///    is over-cautious on top of the max (quiet 1-day windows: 99 % for some parameters; the
///    real WIC day's intervals came out wider than its 6-hour quarters').
///  - With fewer than kMinJackknifeSections weighted sections (windows shorter than 18 h at the
///    default band) S is used alone: a J of 1-4 degrees of freedom would widen or narrow every
///    short window several times on a chance draw. Such windows keep the sandwich's optimism on
///    disturbed records (stated in docs/robust_estimation.md).
/// Measured coverage (disturbed, 50 seeds, 5 days, 40 sections): S 84.7 %, J 92.2 %,
/// (t/1.96)^2 J 93.3 %, this max(S, J) 93.6 %, max(S, (t/1.96)^2 J) 94.2 %; the same records
/// without traffic, spikes and steps: 91.3 / 94.2 / 95.3 / 94.4 / 95.8 %.
Matrix9d combine_covariances(const Matrix9d& sandwich, const JackknifeResult& jack) {
  if (jack.sections < kMinJackknifeSections || !jack.covariance.allFinite()) return sandwich;
  Eigen::Matrix<double, 9, 1> inflate;
  for (int k = 0; k < 9; ++k) {
    const double ratio = sandwich(k, k) > 0.0 ? jack.covariance(k, k) / sandwich(k, k) : 1.0;
    inflate(k) = std::sqrt(std::max(1.0, ratio));
  }
  return inflate.asDiagonal() * sandwich * inflate.asDiagonal();
}

}  // namespace

WindowEstimate RobustFdEstimator::estimate(const Eigen::Ref<const Readings>& reference_nT,
                                           const Eigen::Ref<const Readings>& test_nT, double sample_period_s) {
  if (reference_nT.rows() != test_nT.rows()) {
    throw std::invalid_argument("RobustFdEstimator: reference and test have different lengths");
  }
  if (!(sample_period_s > 0.0)) throw std::invalid_argument("RobustFdEstimator: sample period <= 0");
  const RobustSettings& rs = settings_.robust;
  diagnostics_ = RobustDiagnostics{};
  const std::size_t length = static_cast<std::size_t>(reference_nT.rows());
  const double duration_s = static_cast<double>(length) * sample_period_s;

  // Step 1: n0 from Eq. 2 and the residual screen (two passes).
  FdWlseEstimator plain(settings_);
  WindowEstimate initial = plain.estimate(reference_nT, test_nT, sample_period_s);
  initial.method = "robust";
  if (initial.quality == Quality::kNotFinite || initial.quality == Quality::kTooFewSamples ||
      !initial.n.allFinite()) {
    return initial;
  }
  Readings reference = reference_nT, test = test_nT;
  diagnostics_.screened.assign(length, 0);
  if (rs.screen) {
    Eigen::Matrix3d n0 = initial.n;
    for (int pass = 0; pass < 2; ++pass) {
      std::vector<char> mask = screen_residual(reference_nT, test_nT, n0, sample_period_s, rs);
      reference = reference_nT;
      test = test_nT;
      detail::fill_masked(reference, test, mask);
      diagnostics_.screened = std::move(mask);
      if (pass == 0) {
        const WindowEstimate again = plain.estimate(reference, test, sample_period_s);
        if (again.n.allFinite()) n0 = again.n;
      }
    }
  }
  const std::size_t screened = static_cast<std::size_t>(
      std::count(diagnostics_.screened.begin(), diagnostics_.screened.end(), 1));

  // Band: configured, or chosen from the coherence of the cleaned records.
  double band_low = settings_.band_low_hz, band_high = settings_.band_high_hz;
  if (rs.auto_band) {
    BandSelectionSettings bs;
    bs.search_low_hz = rs.band_search_low_hz;
    bs.search_high_hz = rs.band_search_high_hz;
    bs.min_coherence = rs.min_band_coherence;
    bs.min_band_harmonics = settings_.min_harmonics;
    diagnostics_.band = select_band(reference, test, sample_period_s, bs);
    if (diagnostics_.band.ok) {
      band_low = diagnostics_.band.low_hz;
      band_high = diagnostics_.band.high_hz;
    }
  }

  // Step 2: sections and cells. A section must reach down to band_low with its 2nd harmonic.
  const double section_s = std::max(rs.section_s, 2.0 / band_low);  // s
  const std::size_t k_sections =
      std::max<std::size_t>(1, static_cast<std::size_t>(std::floor(duration_s / section_s + 1e-9)));
  std::vector<Cell> cells;
  std::vector<std::size_t> section_first(k_sections + 1);
  for (std::size_t s = 0; s <= k_sections; ++s) section_first[s] = length * s / k_sections;
  std::vector<double> column;
  std::vector<Eigen::VectorXcd> spectra(6);
  for (std::size_t s = 0; s < k_sections; ++s) {
    const std::size_t first = section_first[s], count = section_first[s + 1] - first;
    column.resize(count);
    for (int c = 0; c < 6; ++c) {
      const auto& src = c < 3 ? reference : test;
      for (std::size_t i = 0; i < count; ++i) column[i] = src(static_cast<Eigen::Index>(first + i), c % 3);
      detail::detrend(column.data(), count);
      impl_->dft.transform(column.data(), count, spectra[static_cast<std::size_t>(c)]);
    }
    const double section_duration = static_cast<double>(count) * sample_period_s;
    const long j0 = std::max(1L, static_cast<long>(std::ceil(band_low * section_duration - 1e-9)));
    const long j1 = std::min(static_cast<long>(std::floor(band_high * section_duration + 1e-9)),
                             static_cast<long>((count - 1) / 2));
    for (long j = j0; j <= j1; ++j) {
      Cell cell;
      cell.section = static_cast<int>(s);
      cell.frequency_hz = static_cast<double>(j) / section_duration;
      cell.g = std::pow(2.0 * M_PI * static_cast<double>(j) / static_cast<double>(count), settings_.gamma);
      cell.length = count;
      for (int k = 0; k < 3; ++k) {
        cell.x(k) = spectra[static_cast<std::size_t>(k)](j);
        cell.y(k) = spectra[static_cast<std::size_t>(k + 3)](j);
      }
      cells.push_back(cell);
    }
  }
  diagnostics_.sections = k_sections;
  diagnostics_.section_samples = length / k_sections;
  diagnostics_.cells = cells.size();

  WindowEstimate result = initial;  // keeps samples, period; everything else is overwritten
  result.method = "robust";
  result.band_low_hz = band_low;
  result.band_high_hz = band_high;
  result.harmonic_first = static_cast<int>(std::max(1L, static_cast<long>(std::ceil(band_low * duration_s - 1e-9))));
  result.harmonic_last = static_cast<int>(std::floor(band_high * duration_s + 1e-9));
  result.screened_fraction = static_cast<double>(screened) / static_cast<double>(length);
  if (cells.size() < 8) {
    std::ostringstream text;
    text << "only " << cells.size() << " section harmonics in " << band_low << "-" << band_high << " Hz";
    return detail::failed_window_estimate(result, Quality::kTooFewSamples, text.str());
  }
  // Scale bins: cells in frequency order, groups of at least max(40, 3K) cells.
  {
    std::vector<std::size_t> order(cells.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return cells[a].frequency_hz < cells[b].frequency_hz; });
    const std::size_t per_bin = std::max<std::size_t>(40, 3 * k_sections);
    const std::size_t bins = std::max<std::size_t>(1, cells.size() / per_bin);
    for (std::size_t r = 0; r < order.size(); ++r) cells[order[r]].bin = static_cast<int>(std::min(bins - 1, r / per_bin));
  }
  const std::size_t bins = static_cast<std::size_t>(
      1 + std::max_element(cells.begin(), cells.end(), [](const Cell& a, const Cell& b) { return a.bin < b.bin; })->bin);

  IrlsResult fit = irls(cells, k_sections, bins, rs, sample_period_s);
  if (!fit.ok) {
    return detail::failed_window_estimate(result, Quality::kIllConditioned, "weighted A is singular: no signal in the band");
  }

  // Step 4: delay, and its removal when significant.
  if (rs.estimate_delay) {
    DelaySettings ds;
    ds.low_hz = std::max(band_low, 2.0 / duration_s);
    ds.high_hz = std::max(rs.delay_max_hz, 2.0 * ds.low_hz);
    try {
      diagnostics_.delay = estimate_delay(reference, test, fit.n, sample_period_s, ds);
    } catch (const InputError&) {
      diagnostics_.delay = DelayEstimate{};
    }
    const DelayEstimate& d = diagnostics_.delay;
    if (d.ok) {
      result.delay_s = d.delay_s;
      result.delay_ci95_s = d.ci95_s;
      if (rs.correct_delay && std::abs(d.delay_s) > 2.0 * d.stderr_s) {
        for (Cell& cell : cells) cell.y *= std::polar(1.0, 2.0 * M_PI * cell.frequency_hz * d.delay_s);
        IrlsResult again = irls(cells, k_sections, bins, rs, sample_period_s);
        if (again.ok) {
          fit = std::move(again);
          diagnostics_.delay_corrected = true;
        }
      }
    }
  }
  diagnostics_.section_weights = fit.section_weight;
  diagnostics_.iterations = fit.iterations;

  // Last IRLS step with the final weights frozen (and, in ratio mode, the EIV fixed point
  // iterated to convergence), so that n, the sandwich and the jackknife below all belong to the
  // same weighted estimating equation.
  {
    const WeightedSolution last = solve_frozen(cells, fit.weight, fit.scale2, rs, sample_period_s, -1, fit.n);
    if (last.ok) static_cast<WeightedSolution&>(fit) = last;
  }
  diagnostics_.eiv_applied = fit.eiv_applied;
  diagnostics_.eiv_noise = fit.noise;
  diagnostics_.n_uncorrected = fit.n_uncorrected;

  // Step 6a: sandwich covariance with the final weights.
  NoiseSpectrum given;
  given.white_nT = rs.reference_white_nT;
  given.pink_nT_per_sqrt_hz = rs.reference_pink_nT_per_sqrt_hz;
  const double share = reference_share_of_residual(rs.eiv_noise_ratio);
  std::vector<Eigen::Vector3d> scale2(bins, Eigen::Vector3d::Zero());
  {
    std::vector<std::vector<double>> per_bin(bins * 3);
    for (const Cell& cell : cells) {
      const Eigen::Vector3d e2 = (cell.y - fit.n.transpose() * cell.x).cwiseAbs2();
      for (int l = 0; l < 3; ++l) per_bin[static_cast<std::size_t>(cell.bin) * 3 + static_cast<std::size_t>(l)].push_back(e2(l));
    }
    for (std::size_t b = 0; b < bins; ++b)
      for (int l = 0; l < 3; ++l) scale2[b](l) = detail::median(per_bin[b * 3 + static_cast<std::size_t>(l)]) / kLn2;
  }
  Eigen::Matrix<double, 9, 9> omega = Eigen::Matrix<double, 9, 9>::Zero();
  Eigen::Matrix<double, 9, 1> score;
  Eigen::Vector3d residual_power = Eigen::Vector3d::Zero(), test_power = Eigen::Vector3d::Zero();
  Eigen::Vector3d inband_variance = Eigen::Vector3d::Zero();
  double weight_sum = 0.0, weight_max_sum = 0.0;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const Cell& cell = cells[i];
    const double w = fit.weight[i];
    weight_max_sum += 1.0;
    weight_sum += w;
    const Eigen::Vector3cd e = cell.y - fit.n.transpose() * cell.x;
    const double wg = w * cell.g;
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    if (fit.eiv_applied) {
      d = rs.eiv == EivCorrection::kGiven
              ? given.expected_periodogram(cell.frequency_hz, sample_period_s, cell.length)
              : ratio_noise_power(e.cwiseAbs2(), scale2[static_cast<std::size_t>(cell.bin)], share);
    }
    for (int l = 0; l < 3; ++l) {
      score.segment<3>(3 * l) = wg * ((cell.x * std::conj(e(l))).real() + d.cwiseProduct(fit.n.col(l)));
    }
    omega.noalias() += score * score.transpose();
    residual_power += w * e.cwiseAbs2();
    test_power += w * cell.y.cwiseAbs2();
    const double l2 = static_cast<double>(cell.length) * static_cast<double>(cell.length);
    inband_variance += (2.0 / l2) * e.cwiseAbs2() / static_cast<double>(k_sections);
  }
  const double effective = std::max(weight_sum, 4.0);
  const double dof_correction = 2.0 * effective / (2.0 * effective - 3.0);
  Eigen::Matrix<double, 9, 9> bread = Eigen::Matrix<double, 9, 9>::Zero();
  for (int l = 0; l < 3; ++l) bread.block<3, 3>(3 * l, 3 * l) = fit.a_inverse;
  const Eigen::Matrix<double, 9, 9> cov_col = dof_correction * bread * omega * bread.transpose();
  Matrix9d sandwich;
  for (int r = 0; r < 9; ++r) {
    for (int q = 0; q < 9; ++q) {
      // n(k, l) sits at 3 l + k in vec_col(n) and at 3 k + l in row-major vec(n).
      sandwich(r, q) = cov_col(3 * (r % 3) + r / 3, 3 * (q % 3) + q / 3);
    }
  }

  // Step 6b: delete-one-section jackknife of vec(n) with the same final weights.
  const JackknifeResult jack = section_jackknife(cells, fit, k_sections, rs, sample_period_s);
  diagnostics_.covariance_sandwich = sandwich;
  diagnostics_.covariance_jackknife = jack.covariance;
  diagnostics_.jackknife_sections = jack.sections;
  result.n = fit.n;
  result.n_covariance = combine_covariances(sandwich, jack);
  result.parameters = decompose(result.n, result.n_covariance);
  result.downweighted_fraction = 1.0 - weight_sum / std::max(weight_max_sum, 1.0);

  // Trend (test frame, nT/day): the trend column of Eq. 2 on the screened records, with its
  // sandwich standard error. The sections are detrended one by one, so the robust fit itself
  // has no single trend; the screened records no longer hold the transients that would bias it.
  {
    const WindowEstimate trend_fit = plain.estimate(reference, test, sample_period_s);
    result.trend_nT_per_day = trend_fit.trend_nT_per_day;
    result.trend_stderr_nT_per_day = trend_fit.trend_stderr_nT_per_day;
  }

  // Quality figures, as for Eq. 2 but over the weighted cells.
  result.coherence = Eigen::Vector3d::Ones() - residual_power.cwiseQuotient(test_power);
  result.residual_rms_nT = inband_variance.cwiseSqrt();
  apply_quality_rules(result, fit.a, static_cast<long>(cells.size()), "section harmonics", settings_);
  return result;
}

// ---------------------------------------------------------------------------------------------

WindowEstimator::WindowEstimator(const EstimatorSettings& settings) : settings_(settings) {
  settings_.validate();
  if (settings_.method == EstimatorMethod::kRobust) robust_ = std::make_unique<RobustFdEstimator>(settings_);
}

WindowEstimator::~WindowEstimator() = default;

const RobustDiagnostics* WindowEstimator::robust_diagnostics() const {
  return robust_ ? &robust_->diagnostics() : nullptr;
}

WindowEstimate WindowEstimator::estimate(const Eigen::Ref<const Readings>& reference_nT,
                                         const Eigen::Ref<const Readings>& test_nT, double sample_period_s) {
  if (robust_) return robust_->estimate(reference_nT, test_nT, sample_period_s);
  EstimatorSettings s = settings_;
  const double duration_s = static_cast<double>(reference_nT.rows()) * sample_period_s;
  if (s.robust.auto_band && reference_nT.allFinite() && test_nT.allFinite() && reference_nT.rows() >= 64) {
    BandSelectionSettings bs;
    bs.search_low_hz = s.robust.band_search_low_hz;
    bs.search_high_hz = s.robust.band_search_high_hz;
    bs.min_coherence = s.robust.min_band_coherence;
    bs.min_band_harmonics = s.min_harmonics;
    const BandSelection band = select_band(reference_nT, test_nT, sample_period_s, bs);
    if (band.ok) {
      s.band_low_hz = band.low_hz;
      s.band_high_hz = band.high_hz;
    }
  }
  FdWlseEstimator plain(s);
  WindowEstimate e = plain.estimate(reference_nT, test_nT, sample_period_s);
  e.method = "plain";
  e.band_low_hz = static_cast<double>(e.harmonic_first) / duration_s;
  e.band_high_hz = static_cast<double>(e.harmonic_last) / duration_s;
  if (s.robust.estimate_delay && e.n.allFinite()) {
    DelaySettings ds;
    ds.low_hz = std::max(e.band_low_hz, 2.0 / duration_s);
    ds.high_hz = std::max(s.robust.delay_max_hz, 2.0 * ds.low_hz);
    const DelayEstimate d = estimate_delay(reference_nT, test_nT, e.n, sample_period_s, ds);
    if (d.ok) {
      e.delay_s = d.delay_s;
      e.delay_ci95_s = d.ci95_s;
    }
  }
  return e;
}

}  // namespace magnetometer_insitu_calibration
