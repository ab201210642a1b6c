// Temperature terms of the test record: see temperature_regression.hpp.
#include "magnetometer_insitu_calibration/estimation/temperature_regression.hpp"

#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"  // the t quantile
#include "spectral_tools.hpp"

#include <Eigen/Cholesky>

#include <cmath>
#include <complex>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace magnetometer_insitu_calibration {

namespace {

constexpr double kSecondsPerDay = 86400.0;

Eigen::VectorXd centred(const Eigen::VectorXd& x) { return x.array() - x.mean(); }

/// The columns v_l = u (dR n0)_l, centred (N x 3).
Eigen::MatrixXd product_columns(const Eigen::Ref<const Readings>& reference_nT, const Eigen::VectorXd& u,
                                const Eigen::Matrix3d& n0) {
  const Eigen::RowVector3d mean = reference_nT.colwise().mean();
  const Eigen::MatrixXd field = (reference_nT.rowwise() - mean) * n0;  // dR n0, N x 3
  Eigen::MatrixXd v = field.array().colwise() * u.array();
  for (int l = 0; l < 3; ++l) v.col(l) = centred(v.col(l));
  return v;
}

/// The regression of Eq. 2 with the temperature columns, over harmonics first..last of the window.
/// Columns, centred: dR (0..2, nT), tau (3, days from the window's middle), u (4, degC),
/// v_0..v_2 (5..7, nT degC), T (8..10, nT); `transforms` holds the DFT of each.
struct BandRegression {
  std::vector<Eigen::VectorXcd> transforms;
  long first = 0, last = 0;  ///< harmonic numbers of the band
  int p = 0;                 ///< regressors per component: dR (3), tau (with trend), u, v_l
  bool trend = true;
  double gamma = 1.0;        ///< weights lambda^gamma
  Eigen::Index n = 0;        ///< samples in the window

  /// Regressors of component l at harmonic j: dR, tau (with trend), u, v_l.
  void regressors(int l, long j, Eigen::VectorXcd& x) const {
    x.resize(p);
    int c = 0;
    for (int k = 0; k < 3; ++k) x(c++) = transforms[k](j);
    if (trend) x(c++) = transforms[3](j);
    x(c++) = transforms[4](j);
    x(c++) = transforms[5 + l](j);
  }
  /// Weight of harmonic j: lambda_j^gamma, lambda_j = 2 pi j / n (radians per sample).
  double weight(long j) const {
    return std::pow(2.0 * M_PI * static_cast<double>(j) / static_cast<double>(n), gamma);
  }
  /// DFT of test component l.
  const Eigen::VectorXcd& test(int l) const { return transforms[static_cast<std::size_t>(8 + l)]; }
};

/// The DFTs of the regression's columns (see BandRegression).
std::vector<Eigen::VectorXcd> column_transforms(const Eigen::Ref<const Readings>& reference_nT,
                                                const Eigen::Ref<const Readings>& test_nT,
                                                const Eigen::Ref<const Eigen::VectorXd>& temperature_C,
                                                double sample_period_s, const Eigen::Matrix3d& n0) {
  const Eigen::Index n = reference_nT.rows();
  const Eigen::VectorXd u = centred(temperature_C);
  const Eigen::MatrixXd v = product_columns(reference_nT, u, n0);
  std::vector<Eigen::VectorXd> series;
  for (int k = 0; k < 3; ++k) series.push_back(centred(reference_nT.col(k)));
  Eigen::VectorXd tau(n);
  for (Eigen::Index i = 0; i < n; ++i) tau(i) = (static_cast<double>(i) - 0.5 * static_cast<double>(n - 1)) * sample_period_s / kSecondsPerDay;
  series.push_back(tau);
  series.push_back(u);
  for (int l = 0; l < 3; ++l) series.push_back(v.col(l));
  for (int l = 0; l < 3; ++l) series.push_back(centred(test_nT.col(l)));
  detail::RealDft dft;
  std::vector<Eigen::VectorXcd> w(series.size());
  for (std::size_t c = 0; c < series.size(); ++c) dft.transform(series[c].data(), static_cast<std::size_t>(n), w[c]);
  return w;
}

/// Per component l: A_l, c_l, b_l = A_l^-1 c_l (solved with A scaled to unit diagonal) into
/// a_inverse[l] and b[l], and the coupling columns of (a_l, s_l) into fit.coupling. False (the
/// coupling of the components before filled) when a component's columns are singular.
bool solve_components(const BandRegression& r, std::vector<Eigen::MatrixXd>& a_inverse, std::vector<Eigen::VectorXd>& b,
                      TemperatureFit& fit) {
  const int p = r.p;
  Eigen::VectorXcd x;
  for (int l = 0; l < 3; ++l) {
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(p, p);
    Eigen::VectorXd c = Eigen::VectorXd::Zero(p);
    for (long j = r.first; j <= r.last; ++j) {
      r.regressors(l, j, x);
      const double g = r.weight(j);
      a.noalias() += g * (x * x.adjoint()).real();
      c.noalias() += g * (x * std::conj(r.test(l)(j))).real();
    }
    const Eigen::VectorXd scale = a.diagonal().cwiseMax(std::numeric_limits<double>::min()).cwiseSqrt().cwiseInverse();
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(scale.asDiagonal() * a * scale.asDiagonal());
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return false;
    a_inverse[l] = scale.asDiagonal() * ldlt.solve(Eigen::MatrixXd::Identity(p, p)) * scale.asDiagonal();
    b[l] = a_inverse[l] * c;
    // Coupling: removing a_l u + s_l v_l from T_l and solving Eq. 2 for n(:, l) again moves it by
    // -A_RR^-1 [A_Ru, A_Rv] d(a_l, s_l), with the field block of the same sums.
    const Eigen::Matrix3d a_rr = a.topLeftCorner<3, 3>();
    Eigen::Matrix<double, 3, 2> a_rt;
    a_rt.col(0) = a.block(0, p - 2, 3, 1);
    a_rt.col(1) = a.block(0, p - 1, 3, 1);
    const Eigen::Matrix<double, 3, 2> g_l = -a_rr.ldlt().solve(a_rt);
    for (int k = 0; k < 3; ++k) {
      fit.coupling(3 * k + l, 2 * l) = g_l(k, 0);
      fit.coupling(3 * k + l, 2 * l + 1) = g_l(k, 1);
    }
  }
  return true;
}

/// Covariance (3p x 3p) of the three components' coefficients b: the sandwich over the three
/// components together (cross terms kept), as fd_wlse.cpp, with the 2M / (2M - p) correction.
Eigen::MatrixXd sandwich_covariance(const BandRegression& r, const std::vector<Eigen::MatrixXd>& a_inverse,
                                    const std::vector<Eigen::VectorXd>& b) {
  const int p = r.p;
  const long harmonics = r.last - r.first + 1;
  Eigen::VectorXcd x;
  Eigen::MatrixXd omega = Eigen::MatrixXd::Zero(3 * p, 3 * p);
  Eigen::VectorXd s(3 * p);
  for (long j = r.first; j <= r.last; ++j) {
    const double g = r.weight(j);
    for (int l = 0; l < 3; ++l) {
      r.regressors(l, j, x);
      const std::complex<double> e = r.test(l)(j) - (x.transpose() * b[l].cast<std::complex<double>>())(0);
      s.segment(l * p, p) = g * (x * std::conj(e)).real();
    }
    omega.noalias() += s * s.transpose();
  }
  const double dof_correction = 2.0 * static_cast<double>(harmonics) / (2.0 * static_cast<double>(harmonics) - p);
  Eigen::MatrixXd bread = Eigen::MatrixXd::Zero(3 * p, 3 * p);
  for (int l = 0; l < 3; ++l) bread.block(l * p, l * p, p, p) = a_inverse[l];
  return dof_correction * bread * omega * bread.transpose();
}

/// The fit's coefficients a_l (nT/degC), s_l (ppm/degC), their covariance and 95 % intervals
/// (t quantile of fit.dof) from b and the sandwich covariance `cov` of p regressors per component.
void store_coefficients(const std::vector<Eigen::VectorXd>& b, const Eigen::MatrixXd& cov, int p, TemperatureFit& fit) {
  const double t95 = student_t_two_sided_quantile(0.05, fit.dof);
  for (int l = 0; l < 3; ++l) {
    for (int q = 0; q < 3; ++q) {
      for (int i = 0; i < 2; ++i)
        for (int k = 0; k < 2; ++k) fit.covariance(2 * l + i, 2 * q + k) = cov(l * p + p - 2 + i, q * p + p - 2 + k);
    }
    const double a_l = b[l](p - 2), s_l = b[l](p - 1);
    const double var_a = fit.covariance(2 * l, 2 * l), var_s = fit.covariance(2 * l + 1, 2 * l + 1);
    fit.apparent_nT_per_C(l) = a_l;
    fit.apparent_ci95_nT_per_C(l) = t95 * std::sqrt(std::max(0.0, var_a));
    fit.scale_ppm_per_C(l) = 1e6 * s_l;
    fit.scale_ci95_ppm_per_C(l) = 1e6 * t95 * std::sqrt(std::max(0.0, var_s));
  }
}

}  // namespace

TemperatureFit fit_temperature(const Eigen::Ref<const Readings>& reference_nT, const Eigen::Ref<const Readings>& test_nT,
                               const Eigen::Ref<const Eigen::VectorXd>& temperature_C, double sample_period_s,
                               const Eigen::Matrix3d& n0, const TemperatureBand& band) {
  const Eigen::Index n = reference_nT.rows();
  if (test_nT.rows() != n || temperature_C.size() != n) {
    throw std::invalid_argument("fit_temperature: reference, test and temperature of different lengths");
  }
  TemperatureFit fit;
  if (n < 16) {
    fit.text = "temperature terms not fitted: window too short";
    return fit;
  }
  if (!temperature_C.allFinite()) {
    fit.text = "temperature missing (NaN) in the window: estimated without temperature terms";
    return fit;
  }
  fit.reference_C = temperature_C.mean();
  fit.range_C = temperature_C.maxCoeff() - temperature_C.minCoeff();
  fit.mean_field_nT = (reference_nT.colwise().mean() * n0).transpose();
  if (!(fit.range_C >= band.min_range_C)) {
    std::ostringstream text;
    text.precision(3);
    text << "temperature range " << fit.range_C << " degC below " << band.min_range_C
         << " degC: estimated without temperature terms";
    fit.text = text.str();
    return fit;
  }

  BandRegression regression;
  const double duration_s = static_cast<double>(n) * sample_period_s;
  regression.first = std::max(1L, static_cast<long>(std::ceil(band.low_hz * duration_s - 1e-9)));
  regression.last = std::min(static_cast<long>(std::floor(band.high_hz * duration_s + 1e-9)), static_cast<long>((n - 1) / 2));
  regression.p = band.trend ? 6 : 5;  // dR (3), tau, u, v_l
  const int p = regression.p;
  const long harmonics = regression.last - regression.first + 1;
  if (harmonics < p + 2) {
    fit.text = "temperature terms not fitted: too few harmonics in the band";
    return fit;
  }
  regression.trend = band.trend;
  regression.gamma = band.gamma;
  regression.n = n;
  regression.transforms = column_transforms(reference_nT, test_nT, temperature_C, sample_period_s, n0);

  std::vector<Eigen::MatrixXd> a_inverse(3);
  std::vector<Eigen::VectorXd> b(3);
  if (!solve_components(regression, a_inverse, b, fit)) {
    fit.text = "temperature columns singular in the band: estimated without temperature terms";
    return fit;
  }
  const Eigen::MatrixXd cov = sandwich_covariance(regression, a_inverse, b);
  fit.dof = 2.0 * static_cast<double>(harmonics) - p;
  store_coefficients(b, cov, p, fit);
  refer_offset_to_mean_field(fit, fit.mean_field_nT);
  fit.fitted = true;
  std::ostringstream text;
  text.precision(3);
  text << "temperature terms fitted; n at " << std::fixed << fit.reference_C << " degC (range " << fit.range_C << " degC)";
  fit.text = text.str();
  return fit;
}

void refer_offset_to_mean_field(TemperatureFit& fit, const Eigen::Vector3d& mean_field_nT) {
  fit.mean_field_nT = mean_field_nT;
  const double t95 = student_t_two_sided_quantile(0.05, fit.dof);
  for (int l = 0; l < 3; ++l) {
    const double f = mean_field_nT(l), s_l = 1e-6 * fit.scale_ppm_per_C(l);
    const double var_a = fit.covariance(2 * l, 2 * l), var_s = fit.covariance(2 * l + 1, 2 * l + 1);
    const double cov_as = fit.covariance(2 * l, 2 * l + 1);
    fit.offset_nT_per_C(l) = fit.apparent_nT_per_C(l) - s_l * f;
    fit.offset_ci95_nT_per_C(l) = t95 * std::sqrt(std::max(0.0, var_a + f * f * var_s - 2.0 * f * cov_as));
  }
}

Readings remove_temperature_terms(const Eigen::Ref<const Readings>& reference_nT, const Eigen::Ref<const Readings>& test_nT,
                                  const Eigen::Ref<const Eigen::VectorXd>& temperature_C, const Eigen::Matrix3d& n0,
                                  const TemperatureFit& fit) {
  Readings out = test_nT;
  if (!fit.fitted) return out;
  const Eigen::VectorXd u = temperature_C.array() - fit.reference_C;
  const Eigen::MatrixXd v = product_columns(reference_nT, u, n0);
  for (int l = 0; l < 3; ++l) {
    out.col(l) -= fit.apparent_nT_per_C(l) * u + 1e-6 * fit.scale_ppm_per_C(l) * v.col(l);
  }
  return out;
}

}  // namespace magnetometer_insitu_calibration
