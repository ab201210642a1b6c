// FD-WLSE of the calibration matrix (Eq. 2 of Marusenkov et al.; Nielsen 2005) and its
// covariance.
//
// Notation. R, T: N x 3 readings (nT) at sample period dt. With the trend column the regressors
// are X = [R, tau] (N x p, p = 4; tau = time from the window centre in days), otherwise X = R
// (p = 3). w_X(lambda_j) is the DFT of the columns of X at lambda_j = 2 pi j / N; FFTW's sign
// convention (e^{-i...}) and origin (t = 0) differ from the paper's w, but every quantity below
// is a product w_k w_l^*, in which both differences cancel, and the 1/(2 pi N) normalisation
// cancels between the two sums of Eq. 2.
//
//   A = sum_{j=m0..m} lambda_j^gamma Re(w_X(j) w_X(j)^H)          (p x p)
//   C = sum_{j=m0..m} lambda_j^gamma Re(w_X(j) w_T(j)^H)          (p x 3)
//   B = A^{-1} C,   n = B(0:3, :),   trend = B(3, :)   (nT/day)          -- Eq. 2
//
// Covariance (frequency-domain sandwich, valid for coloured / long-range dependent errors
// because each harmonic's own residual enters): with residual DFTs e_l(j) = w_T,l(j) -
// B(:,l)^T w_X(j) and s_j,l = lambda_j^gamma Re(w_X(j) e_l(j)^*) stacked over l = 0..2 into S_j,
//
//   Cov(vec_col B) = c * (I_3 (x) A^{-1}) [ sum_j S_j S_j^T ] (I_3 (x) A^{-1}),
//   c = 2M / (2M - p)   (M harmonics give 2M real equations for p unknowns per column).
//
// Harmonics of different frequency are asymptotically uncorrelated, so the middle sum estimates
// the variance of sum_j s_j; cross-column terms keep the covariance between test components.
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "failed_window_estimate.hpp"
#include "sandwich_cells.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <mutex>
#include <sstream>

namespace magnetometer_insitu_calibration {
namespace {

constexpr double kSecondsPerDay = 86400.0;

/// FFTW's planner is not thread-safe (execution of distinct plans is).
std::mutex& fftw_planner_mutex() {
  static std::mutex mutex;
  return mutex;
}

}  // namespace

std::mutex& fftw_planner_lock() { return fftw_planner_mutex(); }

/// FFTW buffers and a batched real-to-complex plan for the data columns of length `length` (R's
/// three, T's, and a remote's when given), stored column after column. The trend column's DFT
/// is known in closed form (trend_dft) and not transformed.
struct FdWlseEstimator::Workspace {
  static constexpr int kPairColumns = 6;
  std::size_t length = 0;
  int columns = 0;
  bool transformed = false;  ///< the last estimate() executed the plan
  double* input = nullptr;
  fftw_complex* output = nullptr;
  fftw_plan plan = nullptr;

  ~Workspace() { release(); }

  std::size_t bins() const { return length / 2 + 1; }

  void prepare(std::size_t new_length, int new_columns) {
    if (plan != nullptr && new_length == length && new_columns == columns) return;
    release();
    length = new_length;
    columns = new_columns;
    input = fftw_alloc_real(length * static_cast<std::size_t>(columns));
    output = fftw_alloc_complex(bins() * static_cast<std::size_t>(columns));
    if (input == nullptr || output == nullptr) throw std::bad_alloc();
    const int n = static_cast<int>(length);
    std::lock_guard<std::mutex> lock(fftw_planner_mutex());
    // FFTW_ESTIMATE: planning costs microseconds and does not touch the arrays.
    plan = fftw_plan_many_dft_r2c(1, &n, columns, input, nullptr, 1, n, output, nullptr, 1,
                                  static_cast<int>(bins()), FFTW_ESTIMATE);
    if (plan == nullptr) throw std::runtime_error("FFTW could not plan a transform of length " +
                                                  std::to_string(length));
  }

  void release() {
    std::lock_guard<std::mutex> lock(fftw_planner_mutex());
    if (plan != nullptr) fftw_destroy_plan(plan);
    if (input != nullptr) fftw_free(input);
    if (output != nullptr) fftw_free(output);
    plan = nullptr;
    input = nullptr;
    output = nullptr;
    length = 0;
    columns = 0;
    transformed = false;
  }

  double* column(int c) { return input + static_cast<std::size_t>(c) * length; }
  std::complex<double> bin(int c, std::size_t j) const {
    const fftw_complex& z = output[static_cast<std::size_t>(c) * bins() + j];
    return {z[0], z[1]};
  }

  /// Loads [R - mean(R), T - mean(T)] (and the remote minus its mean) into the input buffer
  /// (removing the means changes only harmonic 0, which is never used, and keeps rounding
  /// small). Returns false when a column's sum is not finite: a NaN or an infinite reading (the
  /// sum of finite readings in nT cannot overflow).
  bool load(const Eigen::Ref<const Readings>& reference, const Eigen::Ref<const Readings>& test,
            const Readings* remote) {
    const Eigen::Index n = reference.rows();
    for (int c = 0; c < columns; ++c) {
      const auto series = (c < 3 ? reference : (c < 6 ? test : Eigen::Ref<const Readings>(*remote))).col(c % 3);
      const double mean = series.mean();
      if (!std::isfinite(mean)) return false;
      Eigen::Map<Eigen::VectorXd>(column(c), n) = series.array() - mean;
    }
    return true;
  }
};

namespace {

/// The DFT at harmonic j (FFTW's sign and origin) of the trend column tau_i = (i - (N - 1) / 2)
/// dt / day: the centring changes only harmonic 0, so it is dt / day times the ramp's
/// sum_i i e^{-2 pi i j i / N} = -N / (1 - e^{-2 pi i j / N}).
std::complex<double> trend_dft(long j, std::size_t length, double sample_period_s) {
  const double n = static_cast<double>(length);
  const double w = 2.0 * M_PI * static_cast<double>(j) / n;
  return (sample_period_s / kSecondsPerDay) * (-n / (std::complex<double>(1.0, 0.0) - std::polar(1.0, -w)));
}

}  // namespace

namespace {

using VectorP = Eigen::Matrix<std::complex<double>, Eigen::Dynamic, 1>;

/// The band's harmonics of the transformed window: regressors x = [R, tau], instruments z (the
/// remote's [C, tau], or x itself), test t; weights lambda^gamma.
struct Harmonics {
  const FdWlseEstimator::Workspace& ws;
  long m0 = 0, m = 0;
  int p = 3;
  bool trend = true, remote = false;
  double sample_period_s = 1.0, gamma = 1.0;
  VectorP x, z;
  Eigen::Vector3cd t;

  void load(long j) {
    const auto bin = static_cast<std::size_t>(j);
    x.resize(p);
    z.resize(p);
    for (int c = 0; c < 3; ++c) x(c) = ws.bin(c, bin);
    if (trend) x(3) = trend_dft(j, ws.length, sample_period_s);
    for (int k = 0; k < 3; ++k) t(k) = ws.bin(3 + k, bin);
    if (!remote) {
      z = x;
      return;
    }
    for (int c = 0; c < 3; ++c) z(c) = ws.bin(6 + c, bin);
    if (trend) z(3) = x(3);  // the trend is its own instrument
  }
  double weight(long j) const {
    return std::pow(2.0 * M_PI * static_cast<double>(j) / static_cast<double>(ws.length), gamma);
  }
};

/// Pass 1: the sums of Eq. 2, A = sum g Re(x x^H) and C = sum g Re(x t^H), and with a remote the
/// instrumental ones, A_z = sum g Re(z x^H), C_z = sum g Re(z t^H), with M_zz = sum g Re(z z^H).
struct Sums {
  Eigen::MatrixXd a, c, a_z, c_z, m_zz;
  double weight_sum = 0.0, weight_squares = 0.0;
};

Sums sum_harmonics(Harmonics& h) {
  const int p = h.p;
  Sums out;
  out.a = out.a_z = out.m_zz = Eigen::MatrixXd::Zero(p, p);
  out.c = out.c_z = Eigen::MatrixXd::Zero(p, 3);
  for (long j = h.m0; j <= h.m; ++j) {
    h.load(j);
    const double g = h.weight(j);
    out.a.noalias() += g * (h.x * h.x.adjoint()).real();
    out.c.noalias() += g * (h.x * h.t.adjoint()).real();
    out.weight_sum += g;
    out.weight_squares += g * g;
    if (!h.remote) continue;
    out.a_z.noalias() += g * (h.z * h.x.adjoint()).real();
    out.c_z.noalias() += g * (h.z * h.t.adjoint()).real();
    out.m_zz.noalias() += g * (h.z * h.z.adjoint()).real();
  }
  return out;
}

/// The field block of a p x p sum with the trend column partialled out (Schur complement).
Eigen::Matrix3d without_trend(const Eigen::MatrixXd& m, const Eigen::MatrixXd& rows_trend,
                              const Eigen::MatrixXd& trend_columns, double trend_trend) {
  if (m.rows() == 3) return m;
  return m.topLeftCorner<3, 3>() - rows_trend.topRightCorner<3, 1>() * trend_columns.bottomLeftCorner<1, 3>() / trend_trend;
}

/// Eq. 2's solve, A scaled to unit diagonal (the trend column, nT^2 day^2, and the field
/// columns, nT^2, differ by many orders of magnitude); false when A is singular.
bool least_squares_solve(const Eigen::MatrixXd& a, const Eigen::MatrixXd& c, Eigen::MatrixXd& b,
                         Eigen::MatrixXd& a_inverse) {
  const Eigen::VectorXd scale = a.diagonal().cwiseMax(std::numeric_limits<double>::min()).cwiseSqrt().cwiseInverse();
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(scale.asDiagonal() * a * scale.asDiagonal());
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return false;
  a_inverse = scale.asDiagonal() * ldlt.solve(Eigen::MatrixXd::Identity(a.rows(), a.cols())) * scale.asDiagonal();
  b = a_inverse * c;
  return true;
}

/// vec_col (p x 3) -> row-major vec(n) of the field rows.
Matrix9d field_block(const Eigen::MatrixXd& cov_col, int p) {
  Matrix9d out;
  for (int r = 0; r < 9; ++r) {
    for (int q = 0; q < 9; ++q) {
      // n(k, l) = B(k, l) sits at l * p + k in vec_col(B) and at 3k + l in row-major vec(n).
      out(r, q) = cov_col((r % 3) * p + r / 3, (q % 3) * p + q / 3);
    }
  }
  return out;
}

/// With a remote: n from its instruments when they predict the local reference strongly enough
/// (remote_reference.hpp), the field block of every sum with the trend partialled out; else the
/// pair's, the refusal stated. Returns whether the remote is used.
bool use_remote(WindowEstimate& result, const Sums& sums, const std::string& name, Eigen::MatrixXd& b,
                Eigen::MatrixXd& a_inverse) {
  RemoteReference& remote = result.remote;
  const int p = static_cast<int>(sums.a.rows());
  const double tt = p == 4 ? sums.a(3, 3) : 1.0;
  const Eigen::Matrix3d m_xx = without_trend(sums.a, sums.a, sums.a, tt);
  const Eigen::Matrix3d m_zz = without_trend(sums.m_zz, sums.m_zz, sums.m_zz, tt);
  const Eigen::Matrix3d m_zx = without_trend(sums.a_z, sums.m_zz, sums.a, tt);
  assess_remote_strength(remote, m_xx, m_zz, m_zx, 2.0 * sums.weight_sum * sums.weight_sum / sums.weight_squares);
  const std::string who = name.empty() ? std::string("the remote") : name;
  std::ostringstream text;
  text.precision(3);
  Eigen::MatrixXd b_z, a_inverse_z;
  if (!(remote.strength >= kMinRemoteStrength) || !instrumental_solve(sums.a_z, sums.c_z, b_z, a_inverse_z)) {
    text << "remote " << who << " refused: it predicts the local reference too weakly (first-stage F "
         << remote.strength << " < " << kMinRemoteStrength << ", smallest canonical coherence "
         << remote.canonical_coherence << "): a different field or a wrong time base; n from the pair alone";
    remote.text = text.str();
    return false;
  }
  text << "remote reference " << who << " (first-stage F " << remote.strength << ", coherence x/y/z "
       << remote.coherence(0) << "/" << remote.coherence(1) << "/" << remote.coherence(2) << ")";
  remote.text = text.str();
  remote.used = true;
  result.eiv = ErrorsInVariables::kRemoteReference;
  b = b_z;
  a_inverse = a_inverse_z;
  return true;
}

/// Pass 2: residual DFTs (local: e = t - B^T x), the sandwich over the harmonics with the score
/// g Re(z conj(e)), the cells it rests on, coherence and residual power; n, its covariance, the
/// trend and the parameters.
void estimate_covariance(WindowEstimate& result, Harmonics& h, const Eigen::MatrixXd& b,
                         const Eigen::MatrixXd& a_inverse) {
  const int p = h.p;
  Eigen::MatrixXd omega = Eigen::MatrixXd::Zero(3 * p, 3 * p);
  Eigen::VectorXd s(3 * p);
  Eigen::Vector3d residual_power = Eigen::Vector3d::Zero(), test_power = Eigen::Vector3d::Zero();
  Eigen::VectorXd zz = Eigen::VectorXd::Zero(p);
  for (long j = h.m0; j <= h.m; ++j) {
    h.load(j);
    const double g = h.weight(j);
    const Eigen::Vector3cd e = h.t - b.transpose() * h.x;
    for (int l = 0; l < 3; ++l) {
      s.segment(l * p, p) = g * (h.z * std::conj(e(l))).real();
      residual_power(l) += std::norm(e(l));
      test_power(l) += std::norm(h.t(l));
    }
    omega.noalias() += s * s.transpose();
    zz += g * h.z.cwiseAbs2();
  }
  {  // the cells behind the sandwich, as many as share it equally (sandwich_cells.hpp): Eq. 2's
     // weights lambda^gamma, one residual power per column; the instruments at unit scale
    const Eigen::VectorXd scale = zz.cwiseMax(std::numeric_limits<double>::min()).cwiseSqrt().cwiseInverse();
    detail::SandwichCells sandwich_cells(p);
    const Eigen::Vector3d one = Eigen::Vector3d::Ones();
    for (int pass = 0; pass < 2; ++pass) {
      for (long j = h.m0; j <= h.m; ++j) {
        h.load(j);
        const VectorP z = scale.cast<std::complex<double>>().asDiagonal() * h.z;
        if (pass == 0) sandwich_cells.add(z, h.weight(j), one);
        else sandwich_cells.share(z, h.weight(j), one);
      }
    }
    const double count = sandwich_cells.count();
    if (std::isfinite(count)) result.covariance_dof = count;  // else the harmonics, as set before
  }
  const long harmonics = h.m - h.m0 + 1;
  const double dof_correction = 2.0 * harmonics / (2.0 * harmonics - p);
  Eigen::MatrixXd bread = Eigen::MatrixXd::Zero(3 * p, 3 * p);
  for (int l = 0; l < 3; ++l) bread.block(l * p, l * p, p, p) = a_inverse;
  const Eigen::MatrixXd cov_b = dof_correction * bread * omega * bread.transpose();  // vec_col(B)
  result.n = b.topRows(3);
  result.n_covariance = field_block(cov_b, p);
  if (h.trend) {
    result.trend_nT_per_day = b.row(3).transpose();
    for (int l = 0; l < 3; ++l) {
      result.trend_stderr_nT_per_day(l) = std::sqrt(std::max(0.0, cov_b(l * p + 3, l * p + 3)));
    }
  }
  result.parameters = decompose(result.n, result.n_covariance, result.covariance_dof);
  result.coherence = (Eigen::Vector3d::Ones() - residual_power.cwiseQuotient(test_power));
  // Parseval for the unnormalised DFT: in-band variance = 2 sum_band |E_j|^2 / N^2.
  result.residual_rms_nT = (2.0 * residual_power).cwiseSqrt() / static_cast<double>(h.ws.length);
}

/// The pair-only estimate (Eq. 2 on the pair) against the remote's: the covariance of their
/// difference from the per-harmonic difference of the two estimators' influence.
void compare_with_pair(WindowEstimate& result, Harmonics& h, const Eigen::MatrixXd& b_pair,
                       const Eigen::MatrixXd& a_inverse_pair, const Eigen::MatrixXd& b,
                       const Eigen::MatrixXd& a_inverse) {
  const int p = h.p;
  Eigen::MatrixXd omega = Eigen::MatrixXd::Zero(3 * p, 3 * p);
  Eigen::VectorXd influence(3 * p);
  for (long j = h.m0; j <= h.m; ++j) {
    h.load(j);
    const double g = h.weight(j);
    const Eigen::Vector3cd e_pair = h.t - b_pair.transpose() * h.x, e = h.t - b.transpose() * h.x;
    for (int l = 0; l < 3; ++l) {
      influence.segment(l * p, p) = a_inverse_pair * (g * (h.x * std::conj(e_pair(l))).real()) -
                                    a_inverse * (g * (h.z * std::conj(e(l))).real());
    }
    omega.noalias() += influence * influence.transpose();
  }
  const long harmonics = h.m - h.m0 + 1;
  omega *= 2.0 * harmonics / (2.0 * harmonics - p);
  assess_pair_difference(result.remote, b_pair.topRows(3), result.n, field_block(omega, p), result.covariance_dof);
}

}  // namespace

FdWlseEstimator::FdWlseEstimator(EstimatorSettings settings)
    : settings_(settings), workspace_(std::make_unique<Workspace>()) {
  settings_.validate();
}

FdWlseEstimator::~FdWlseEstimator() = default;

WindowEstimate FdWlseEstimator::estimate(const Eigen::Ref<const Readings>& reference_nT,
                                         const Eigen::Ref<const Readings>& test_nT, double sample_period_s,
                                         const WindowInputs& inputs) {
  const Readings* remote = inputs.remote_nT;
  if (reference_nT.rows() != test_nT.rows() || (remote != nullptr && remote->rows() != reference_nT.rows())) {
    throw std::invalid_argument("FdWlseEstimator: reference, test and remote have different lengths");
  }
  if (!(sample_period_s > 0.0)) throw std::invalid_argument("FdWlseEstimator: sample period <= 0");

  workspace_->transformed = false;
  const int p = settings_.trend ? 4 : 3;  // regressors
  const std::size_t length = static_cast<std::size_t>(reference_nT.rows());
  WindowEstimate result;
  result.samples = length;
  result.sample_period_s = sample_period_s;
  result.remote.given = remote != nullptr;
  auto fail = [&](Quality q, const std::string& text) { return detail::failed_window_estimate(result, q, text); };

  // Harmonic j has frequency j / (N dt). Sum over m0..m, never the mean (0) nor Nyquist.
  const double duration_s = static_cast<double>(length) * sample_period_s;
  const long m0 = std::max(1L, static_cast<long>(std::ceil(settings_.band_low_hz * duration_s - 1e-9)));
  const long m = std::min(static_cast<long>(std::floor(settings_.band_high_hz * duration_s + 1e-9)),
                          static_cast<long>(length > 0 ? (length - 1) / 2 : 0));
  result.harmonic_first = static_cast<int>(m0);
  result.harmonic_last = static_cast<int>(m);
  const long harmonics = m - m0 + 1;
  result.covariance_dof = static_cast<double>(std::max(0L, harmonics));
  if (length < 16 || harmonics < p + 2) {
    std::ostringstream text;
    text << "window of " << length << " samples (" << duration_s << " s) holds " << std::max(0L, harmonics)
         << " harmonics in " << settings_.band_low_hz << "-" << settings_.band_high_hz
         << " Hz; at least " << p + 2 << " are needed to estimate anything";
    return fail(Quality::kTooFewSamples, text.str());
  }

  Workspace& ws = *workspace_;
  ws.prepare(length, remote != nullptr ? 9 : Workspace::kPairColumns);
  if (!ws.load(reference_nT, test_nT, remote)) return fail(Quality::kNotFinite, "window contains NaN or infinite readings");
  fftw_execute(ws.plan);
  ws.transformed = true;
  Harmonics h{ws, m0, m, p, settings_.trend, remote != nullptr, sample_period_s, settings_.gamma, {}, {}, {}};
  const Sums sums = sum_harmonics(h);
  Eigen::MatrixXd b, a_inverse, b_pair, a_inverse_pair;
  if (!least_squares_solve(sums.a, sums.c, b_pair, a_inverse_pair)) {
    return fail(Quality::kIllConditioned, "A = sum lambda^gamma Re I_RR is singular: no signal in the band");
  }
  b = b_pair;
  a_inverse = a_inverse_pair;
  if (h.remote) h.remote = use_remote(result, sums, inputs.remote_name, b, a_inverse);
  estimate_covariance(result, h, b, a_inverse);
  if (result.remote.used) compare_with_pair(result, h, b_pair, a_inverse_pair, b, a_inverse);
  apply_quality_rules(result, sums.a.topLeftCorner<3, 3>(), harmonics, "harmonics", settings_);
  return result;
}

const std::complex<double>* FdWlseEstimator::last_spectrum(int column) const {
  const Workspace& ws = *workspace_;
  if (!ws.transformed || column < 0 || column >= Workspace::kPairColumns) return nullptr;
  // fftw_complex is double[2], laid out as std::complex<double> (FFTW manual, "Complex numbers").
  return reinterpret_cast<const std::complex<double>*>(ws.output + static_cast<std::size_t>(column) * ws.bins());
}

void apply_quality_rules(WindowEstimate& e, const Eigen::Matrix3d& field_block_of_a, long harmonics,
                         const char* harmonics_noun, const EstimatorSettings& settings) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(field_block_of_a);
  const Eigen::Vector3d ev = eig.eigenvalues();
  e.condition_number = ev(0) > 0.0 ? ev(2) / ev(0) : std::numeric_limits<double>::infinity();
  std::ostringstream text;
  if (harmonics < static_cast<long>(settings.min_harmonics)) {
    e.quality = Quality::kTooFewHarmonics;
    text << harmonics << " " << harmonics_noun << " in the band, fewer than min_harmonics = " << settings.min_harmonics;
  } else if (!(e.condition_number <= settings.max_condition_number)) {
    e.quality = Quality::kIllConditioned;
    text << "condition number " << e.condition_number << " above " << settings.max_condition_number
         << ": too little signal in one direction of the band";
  } else if (e.coherence.minCoeff() < settings.min_coherence) {
    Eigen::Index worst;
    e.coherence.minCoeff(&worst);
    e.quality = Quality::kLowCoherence;
    text << "coherence of component " << worst << " is " << e.coherence(worst) << ", below " << settings.min_coherence;
  } else {
    e.quality = Quality::kOk;
    text << "ok";
  }
  e.quality_text = text.str();
}

}  // namespace magnetometer_insitu_calibration
