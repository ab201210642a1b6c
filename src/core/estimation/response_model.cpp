#include "magnetometer_insitu_calibration/estimation/response_model.hpp"

#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/estimation/column_response.hpp"
#include "spectral_tools.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>

namespace magnetometer_insitu_calibration {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kParameters = 7;  // tau, g_x, g_y, g_z, q_x, q_y, q_z (q = 1 / fc, s)
using Params = Eigen::Matrix<double, kParameters, 1>;

std::complex<double> model(const Params& p, int k, double f) {
  const std::complex<double> delay = std::exp(std::complex<double>(0.0, -2.0 * kPi * f * p(0)));
  return p(1 + k) * delay / std::complex<double>(1.0, f * p(4 + k));
}

/// Weighted residuals (real and imaginary parts, / their standard errors) of the bands used.
Eigen::VectorXd residuals(const Params& p, const std::vector<ResponseBand>& bands) {
  Eigen::VectorXd r(static_cast<Eigen::Index>(bands.size() * 6));
  Eigen::Index i = 0;
  for (const auto& b : bands) {
    const double t = student_t_two_sided_quantile(0.05, 2.0 * (static_cast<double>(b.harmonics) - 2.0));
    for (int k = 0; k < 3; ++k) {
      const std::complex<double> measured = std::polar(b.gain(k), b.phase_deg(k) * kPi / 180.0);
      const std::complex<double> d = measured - model(p, k, b.frequency_hz);
      const double sd = std::max(1e-12, b.gain_ci95(k) / t);
      r(i++) = d.real() / sd;
      r(i++) = d.imag() / sd;
    }
  }
  return r;
}

struct Fit {
  Params p = Params::Zero();
  Eigen::Matrix<double, kParameters, kParameters> covariance = Eigen::Matrix<double, kParameters, kParameters>::Zero();
  double chi2_per_dof = 0.0;
  bool ok = false;
};

/// Levenberg-Marquardt on the weighted residuals, q >= 0 kept by clamping; q_k held at 0 where
/// free_corner(k) is false.
Fit fit(const std::vector<ResponseBand>& bands, double initial_delay_s,
        const Eigen::Array<bool, 3, 1>& free_corner = Eigen::Array<bool, 3, 1>::Constant(true),
        const Params* start = nullptr) {
  Fit out;
  Params p;
  p << initial_delay_s, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0;
  if (start != nullptr) p = *start;
  double lambda = 1e-3;
  Eigen::VectorXd r = residuals(p, bands);
  double cost = r.squaredNorm();
  Eigen::MatrixXd jac(r.size(), kParameters);
  for (int iteration = 0; iteration < 100; ++iteration) {
    for (int c = 0; c < kParameters; ++c) {
      Params q = p;
      const double h = 1e-6 * std::max(1.0, std::abs(p(c)));
      q(c) += h;
      jac.col(c) = (residuals(q, bands) - r) / h;
    }
    for (int k = 0; k < 3; ++k) {
      if (!free_corner(k)) jac.col(4 + k).setZero();
    }
    Eigen::Matrix<double, kParameters, kParameters> jtj = jac.transpose() * jac;
    for (int k = 0; k < 3; ++k) {
      if (!free_corner(k)) jtj(4 + k, 4 + k) = 1.0;  // held: the step leaves it at 0
    }
    const Params g = jac.transpose() * r;
    bool improved = false;
    for (int attempt = 0; attempt < 20 && !improved; ++attempt) {
      Eigen::Matrix<double, kParameters, kParameters> a = jtj;
      a.diagonal() *= 1.0 + lambda;
      Params next = p - a.ldlt().solve(g);
      for (int k = 0; k < 3; ++k) next(4 + k) = std::clamp(next(4 + k), 0.0, 1e4);
      const Eigen::VectorXd rn = residuals(next, bands);
      const double cn = rn.squaredNorm();
      if (std::isfinite(cn) && cn < cost) {
        const double change = cost - cn;
        p = next;
        r = rn;
        cost = cn;
        lambda = std::max(1e-9, lambda / 10.0);
        improved = true;
        if (change < 1e-10 * std::max(1.0, cost)) iteration = 1000;
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) break;
  }
  for (int c = 0; c < kParameters; ++c) {
    Params q = p;
    const double h = 1e-6 * std::max(1.0, std::abs(p(c)));
    q(c) += h;
    jac.col(c) = (residuals(q, bands) - r) / h;
  }
  const int held = 3 - static_cast<int>(free_corner.count());
  Eigen::Matrix<double, kParameters, kParameters> jtj = jac.transpose() * jac;
  for (int k = 0; k < 3; ++k) {
    if (!free_corner(k)) {
      jtj.row(4 + k).setZero();
      jtj.col(4 + k).setZero();
      jtj(4 + k, 4 + k) = 1.0;
    }
  }
  const double dof = static_cast<double>(r.size() - kParameters + held);
  out.p = p;
  out.chi2_per_dof = cost / dof;
  out.covariance = jtj.inverse() * std::max(1.0, out.chi2_per_dof);
  out.ok = out.covariance.allFinite();
  return out;
}

/// How much better the gains alone (|H| of component k over the bands) fit a 1-pole roll-off
/// with 1/fc = q than a flat gain: chi^2(flat) - chi^2(roll-off), each with its best constant g.
/// A delay and a corner share their low-frequency phase (a 1-pole lags by 1 / (2 pi fc) s), so
/// only the gain tells a filter from a delay.
double gain_rolloff_chi2(const std::vector<ResponseBand>& bands, int k, double q) {
  // With weights w, gains x and shape s, the best g leaves chi^2 = sum w x^2 - (sum w x s)^2 / sum w s^2;
  // the sum w x^2 term is common to both models.
  double swx = 0.0, sw = 0.0, swxs = 0.0, swss = 0.0;
  for (const auto& b : bands) {
    const double sd = std::max(1e-12, b.gain_ci95(k) / student_t_two_sided_quantile(0.05, 2.0 * (static_cast<double>(b.harmonics) - 2.0)));
    const double w = 1.0 / (sd * sd), x = b.gain(k), shape = 1.0 / std::hypot(1.0, b.frequency_hz * q);
    swx += w * x;
    sw += w;
    swxs += w * x * shape;
    swss += w * shape * shape;
  }
  return swxs * swxs / swss - swx * swx / sw;
}

}  // namespace

void ResponseModelSettings::validate() const {
  if (!(fit_max_hz > 0.0)) throw InputError("response_model.fit_max_hz", "must be > 0 Hz");
  if (!(min_fit_max_hz > 0.0) || min_fit_max_hz > fit_max_hz) {
    throw InputError("response_model.min_fit_max_hz", "must be > 0 and at most fit_max_hz");
  }
  if (!(max_chi2_per_dof >= 1.0)) throw InputError("response_model.max_chi2_per_dof", "must be >= 1");
  if (!(min_significance > 0.0)) throw InputError("response_model.min_significance", "must be > 0");
  if (!(max_corner_above_fit >= 1.0)) throw InputError("response_model.max_corner_above_fit", "must be >= 1");
}

ResponseModel fit_response_model(const std::vector<ResponseBand>& bands, const ResponseModelSettings& settings) {
  settings.validate();
  ResponseModel m;
  std::vector<ResponseBand> used;
  for (const auto& b : bands) {
    if (b.frequency_hz <= settings.fit_max_hz) used.push_back(b);
  }
  const double initial_delay = summarise_response(used, 0.0, settings.min_fit_max_hz).group_delay_s;
  // Lower the top of the fit band by band until the model fits.
  while (used.size() >= 5 && used.back().frequency_hz >= settings.min_fit_max_hz) {
    // Start each corner where the gains alone put it (a grid over 1/fc; 0 when no roll-off shows)
    // and the delay at the group delay less those corners' lag: from 1/fc = 0 the phase the
    // group delay already holds pushes the corners against their bound and the fit stalls there.
    Params start;
    start << (std::isfinite(initial_delay) ? initial_delay : 0.0), 1.0, 1.0, 1.0, 0.0, 0.0, 0.0;
    for (int k = 0; k < 3; ++k) {
      double best = 0.0;
      for (int i = 0; i <= 40; ++i) {
        const double q = 0.1 / used.back().frequency_hz * std::pow(1000.0, i / 40.0);  // fc from 10 fmax down
        const double gain = gain_rolloff_chi2(used, k, q);
        if (gain > best) {
          best = gain;
          start(4 + k) = q;
        }
      }
      start(0) -= start(4 + k) / (2.0 * kPi) / 3.0;
    }
    const Fit f = fit(used, start(0), Eigen::Array<bool, 3, 1>::Constant(true), &start);
    if (f.ok && f.chi2_per_dof <= settings.max_chi2_per_dof) {
      m.fitted = true;
      m.fit_max_hz = used.back().frequency_hz;
      Eigen::Array<bool, 3, 1> significant;
      for (int k = 0; k < 3; ++k) {
        const double q = f.p(4 + k), se = std::sqrt(f.covariance(4 + k, 4 + k));
        // Significant, inside the fitted range, and seen in the gains (not only in the phase,
        // which a delay explains as well).
        significant(k) = q > settings.min_significance * se && q * m.fit_max_hz * settings.max_corner_above_fit >= 1.0 &&
                         gain_rolloff_chi2(used, k, q) >= settings.min_significance * settings.min_significance;
      }
      // The delay and the corners that count, fitted again without the others (a corner far above
      // the data trades its phase against the delay).
      // It starts from the first fit, the dropped corners' lag (1 / (2 pi fc)) moved into the delay.
      Params start = f.p;
      double common_lag = 0.0;
      for (int k = 0; k < 3; ++k) {
        if (significant(k)) continue;
        common_lag += start(4 + k) / (2.0 * kPi) / 3.0;
        start(4 + k) = 0.0;
      }
      start(0) += common_lag;
      const Fit final_fit = significant.all() ? f : fit(used, start(0), significant, &start);
      m.chi2_per_dof = final_fit.chi2_per_dof;
      m.delay_s = final_fit.p(0);
      m.delay_ci95_s = kNormalQuantile95 * std::sqrt(final_fit.covariance(0, 0));
      for (int k = 0; k < 3; ++k) {
        const double q = final_fit.p(4 + k), se = std::sqrt(f.covariance(4 + k, 4 + k));
        m.inverse_corner_ci95_s(k) = kNormalQuantile95 * se;
        // A corner counts when it is significant AND near the fitted range (at most
        // max_corner_above_fit above it), where its roll-off was seen: far above it, a small fitted
        // 1/fc is what reference noise does to the measured gain at high frequency (errors in
        // variables), not a filter. Checked again on the refit's corner.
        if (significant(k) && q * m.fit_max_hz * settings.max_corner_above_fit >= 1.0) {
          m.inverse_corner_s(k) = q;
          m.corner_hz(k) = 1.0 / q;
          m.applied = true;
        }
      }
      break;
    }
    used.pop_back();
  }
  char text[256];
  if (!m.fitted) {
    std::snprintf(text, sizeof text, "response model: no fit (too few bands or chi2/dof > %.1f above %.3g Hz)",
                  settings.max_chi2_per_dof, settings.min_fit_max_hz);
  } else {
    char corners[3][24];
    for (int k = 0; k < 3; ++k) {
      if (m.inverse_corner_s(k) > 0.0) {
        std::snprintf(corners[k], sizeof corners[k], "%.3g", m.corner_hz(k));
      } else {
        std::snprintf(corners[k], sizeof corners[k], "none");
      }
    }
    std::snprintf(text, sizeof text, "response model to %.3g Hz (chi2/dof %.2f): delay %.2f s, corner x/y/z %s/%s/%s Hz%s",
                  m.fit_max_hz, m.chi2_per_dof, m.delay_s, corners[0], corners[1], corners[2],
                  m.applied ? ", filter removed before estimating n" : "");
  }
  m.text = text;
  return m;
}

Readings remove_modelled_filter(const Readings& test, double period_s, const ResponseModel& model) {
  if (!model.applied || test.rows() < 4) return test;
  Readings out = test;
  ColumnResponse filter(static_cast<std::size_t>(test.rows()));
  for (int k = 0; k < 3; ++k) {
    const double q = model.inverse_corner_s(k);
    if (!(q > 0.0)) continue;
    // 1 + i f q up to the fitted range, held above. In time it is 1 + (q / 2 pi) d/dt: it maps
    // the line a + b t to a + b t + b q / (2 pi).
    const auto inverse_filter = [&](double f) { return std::complex<double>(1.0, std::min(f, model.fit_max_hz) * q); };
    filter.apply(test.col(k), period_s, inverse_filter, q / (2.0 * kPi), out.col(k));
  }
  return out;
}

ResponseModel with_response_model(const WindowEstimateFunction& estimate_again, const Eigen::Ref<const Readings>& reference_nT,
                                  Readings& test_nT, double period_s, const RelativeResponseSettings& response,
                                  const ResponseModelSettings& model, WindowEstimate& estimate, const Readings* remote) {
  ResponseModel fit;
  if (!estimate.n.allFinite()) {
    fit.text = "response model not fitted: the window has no finite estimate";
    return fit;
  }
  fit = fit_response_model(relative_response(reference_nT, test_nT, estimate.n, period_s, response, remote), model);
  if (fit.applied) {
    test_nT = remove_modelled_filter(test_nT, period_s, fit);
    estimate = estimate_again(reference_nT, test_nT, period_s);
  }
  return fit;
}

}  // namespace magnetometer_insitu_calibration
