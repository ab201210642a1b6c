// Agreement of disjoint windows within their intervals: see window_agreement.hpp.
#include "magnetometer_insitu_calibration/estimation/window_agreement.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"

#include <Eigen/Cholesky>

#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

namespace magnetometer_insitu_calibration {

const std::array<const char*, 9> WindowAgreement::kParameterNames = {
    "scale x",        "scale y",        "scale z",       "nonorthogonality xy", "nonorthogonality xz",
    "nonorthogonality yz", "misalignment x", "misalignment y", "misalignment z"};

ValueAndError agreement_parameter(const CalibrationParameters& p, int k) {
  const double q = p.interval_quantile;  // ci95 half-width / standard error
  const int c = k % 3;
  if (k < 3) return {p.scale_ratio(c), p.scale_ratio_ci95(c) / q};
  if (k < 6) return {p.nonorthogonality_deg(c), p.nonorthogonality_ci95_deg(c) / q};
  return {p.misalignment_deg(c), p.misalignment_ci95_deg(c) / q};
}

void WindowAgreementSettings::validate() const {
  if (!(significance > 0.0 && significance < 0.5)) throw InputError("significance", "must be in (0, 0.5)");
}

namespace {

/// Tail probability of a sum of K such forms about their weighted mean (K - 1 of K forms'
/// freedom left): a chi2 scaled to the sum's mean and variance (Satterthwaite), c chi2_f with
/// c = V / 2E, f = 2E^2 / V; chi2 with p (K - 1) dof when every covariance is known.
struct SumReference {
  double mean = 0.0, variance = 0.0;
  void add(const QuadraticFormMoments& m, double share) {
    mean += share * m.mean;
    variance += share * m.variance;
  }
  double tail_probability(double chi2) const {
    if (!(mean > 0.0) || !(variance > 0.0)) return std::numeric_limits<double>::quiet_NaN();
    const double scale = variance / (2.0 * mean), dof = 2.0 * mean * mean / variance;
    return chi2_tail_probability(chi2 / scale, dof);
  }
};

/// The joint chi2 of vec(n) about its generalised least squares mean; NaN when a covariance is
/// not positive definite.
double joint_chi2(const std::vector<const WindowEstimate*>& ok) {
  using Vector9d = Eigen::Matrix<double, 9, 1>;
  std::vector<Matrix9d> inverses;
  Matrix9d information = Matrix9d::Zero();
  Vector9d weighted = Vector9d::Zero();
  std::vector<Vector9d> values;
  for (const WindowEstimate* w : ok) {
    const Eigen::LDLT<Matrix9d> ldlt(w->n_covariance);
    if (!w->n_covariance.allFinite() || ldlt.info() != Eigen::Success || !ldlt.isPositive() ||
        !(ldlt.vectorD().minCoeff() > 0.0)) {
      return std::numeric_limits<double>::quiet_NaN();
    }
    Vector9d v;
    for (int k = 0; k < 9; ++k) v(k) = w->n(k / 3, k % 3);
    inverses.push_back(ldlt.solve(Matrix9d::Identity()));
    information += inverses.back();
    weighted += inverses.back() * v;
    values.push_back(v);
  }
  const Vector9d mean = information.ldlt().solve(weighted);
  double chi2 = 0.0;
  for (std::size_t i = 0; i < values.size(); ++i) chi2 += (values[i] - mean).dot(inverses[i] * (values[i] - mean));
  return chi2;
}

}  // namespace

WindowAgreement check_window_agreement(const std::vector<WindowEstimate>& windows,
                                       const WindowAgreementSettings& settings) {
  settings.validate();
  WindowAgreement out;
  // A parameter's reference needs the variance of each window's t^2, which exists above 4 cells
  // (quadratic_form_moments): a window whose covariance rests on fewer (one strong harmonic
  // carrying its sandwich) is left out, and the text says so.
  std::vector<const WindowEstimate*> ok;
  int too_few_cells = 0;
  for (const WindowEstimate& w : windows) {
    if (w.quality != Quality::kOk) continue;
    if (w.covariance_dof > 4.0) ok.push_back(&w);
    else ++too_few_cells;
  }
  out.windows = static_cast<int>(ok.size());
  std::ostringstream text;
  text << std::setprecision(3);
  if (ok.size() < 2) {
    text << "not assessed: " << ok.size() << " of " << windows.size() << " windows ok (2 needed)";
    if (too_few_cells > 0) text << "; " << too_few_cells << " ok windows left out, covariances from 4 cells or fewer";
    out.text = text.str();
    return out;
  }
  const int dof = out.windows - 1;
  const double share = static_cast<double>(dof) / out.windows;  // of each window's freedom, about the mean
  int largest = 0;
  bool parameter_disagrees = false;
  for (int k = 0; k < 9; ++k) {
    double sw = 0.0, swx = 0.0;
    std::vector<double> value(ok.size()), se(ok.size());
    for (std::size_t i = 0; i < ok.size(); ++i) {
      const ValueAndError p = agreement_parameter(ok[i]->parameters, k);
      value[i] = p.value;
      se[i] = p.se;
      if (!(se[i] > 0.0) || !std::isfinite(se[i]) || !std::isfinite(value[i])) {
        text << "not assessed: window " << i + 1 << " of the ok windows has no usable interval for "
             << WindowAgreement::kParameterNames[k];
        out.text = text.str();
        return out;
      }
      sw += 1.0 / (se[i] * se[i]);
      swx += value[i] / (se[i] * se[i]);
    }
    ParameterAgreement& a = out.parameters[k];
    a.weighted_mean = swx / sw;
    SumReference reference;
    for (std::size_t i = 0; i < ok.size(); ++i) {
      a.chi2 += std::pow((value[i] - a.weighted_mean) / se[i], 2);
      reference.add(quadratic_form_moments(ok[i]->covariance_dof, 1), share);
    }
    a.expected_chi2 = reference.mean;
    a.birge_ratio = std::sqrt(a.chi2 / reference.mean);
    a.p_value = reference.tail_probability(a.chi2);
    parameter_disagrees |= a.p_value < settings.significance / 9.0;
    if (a.birge_ratio > out.parameters[largest].birge_ratio) largest = k;
  }
  out.assessed = true;
  out.joint_dof = 9 * dof;
  out.joint_chi2 = joint_chi2(ok);
  SumReference joint;
  for (const WindowEstimate* w : ok) joint.add(quadratic_form_moments(w->covariance_dof, 9), share);
  out.joint_expected_chi2 = joint.mean;
  out.joint_p_value = std::isfinite(out.joint_chi2) ? joint.tail_probability(out.joint_chi2)
                                                    : std::numeric_limits<double>::quiet_NaN();
  double fewest_cells = std::numeric_limits<double>::infinity();
  for (const WindowEstimate* w : ok) fewest_cells = std::min(fewest_cells, w->covariance_dof);
  out.joint_tested = fewest_cells >= WindowAgreement::kJointTestMinCells;
  out.agree = !parameter_disagrees && !(out.joint_tested && out.joint_p_value < settings.significance);
  text << out.windows << " windows " << (out.agree ? "agree within" : "disagree beyond")
       << " their intervals: joint chi2 " << out.joint_chi2 << " / " << out.joint_dof << " dof";
  if (std::abs(out.joint_expected_chi2 - out.joint_dof) > 0.05 * out.joint_dof)
    text << ", expected " << out.joint_expected_chi2 << " (covariances from few cells)";
  if (std::isfinite(out.joint_p_value))
    text << " (p " << out.joint_p_value;
  else
    text << " (p undefined: T^2's moments need more than 12 cells";
  if (!out.joint_tested)
    text << ", not tested: a covariance from " << fewest_cells << " cells, under "
         << WindowAgreement::kJointTestMinCells << "; the parameters one by one";
  const ParameterAgreement& worst = out.parameters[largest];
  text << "); largest sqrt(chi2/" << worst.expected_chi2 << ") " << worst.birge_ratio
       << ", " << WindowAgreement::kParameterNames[largest] << " (p " << worst.p_value << ")";
  if (too_few_cells > 0) text << "; " << too_few_cells << " ok windows left out, covariances from 4 cells or fewer";
  if (!out.agree) {
    text << ": n is not one matrix through the record, or the intervals are too narrow; the whole record's "
            "intervals are optimistic by up to that factor";
  }
  out.text = text.str();
  return out;
}

}  // namespace magnetometer_insitu_calibration
