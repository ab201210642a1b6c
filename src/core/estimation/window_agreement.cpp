// Agreement of disjoint windows within their intervals: see window_agreement.hpp.
#include "magnetometer_insitu_calibration/estimation/window_agreement.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <cmath>
#include <iomanip>
#include <sstream>

namespace magnetometer_insitu_calibration {

void WindowAgreementSettings::validate() const {
  if (!(significance > 0.0 && significance < 0.5)) throw InputError("significance", "must be in (0, 0.5)");
}

namespace {

/// The one-line verdict of an assessed comparison.
std::string agreement_text(const WindowAgreement& out, const EstimateComparison& c, int too_few_cells) {
  std::ostringstream text;
  text << std::setprecision(3);
  text << out.windows << " windows " << (out.agree ? "agree within" : "disagree beyond")
       << " their intervals: joint chi2 " << out.joint_chi2 << " / " << out.joint_dof << " dof";
  if (std::abs(out.joint_expected_chi2 - out.joint_dof) > 0.05 * out.joint_dof)
    text << ", expected " << out.joint_expected_chi2 << " (covariances from few cells)";
  if (std::isfinite(out.joint_p_value))
    text << " (p " << out.joint_p_value;
  else
    text << " (p undefined: T^2's moments need more than 12 cells";
  if (!out.joint_tested)
    text << ", not tested: a covariance from " << c.fewest_cells << " cells, under " << kJointTestMinCells
         << "; the parameters one by one";
  int largest = 0;
  for (int k = 1; k < 9; ++k)
    if (out.parameters[static_cast<std::size_t>(k)].birge_ratio > out.parameters[static_cast<std::size_t>(largest)].birge_ratio)
      largest = k;
  const ParameterAgreement& worst = out.parameters[static_cast<std::size_t>(largest)];
  text << "); largest sqrt(chi2/" << worst.expected_chi2 << ") " << worst.birge_ratio << ", "
       << kParameters[static_cast<std::size_t>(largest)].name << " (p " << worst.p_value << ")";
  if (too_few_cells > 0) text << "; " << too_few_cells << " ok windows left out, covariances from 4 cells or fewer";
  if (!out.agree) {
    text << ": n is not one matrix through the record, or the intervals are too narrow; the whole record's "
            "intervals are optimistic by up to that factor";
  }
  return text.str();
}

}  // namespace

WindowAgreement check_window_agreement(const std::vector<WindowEstimate>& windows,
                                       const WindowAgreementSettings& settings) {
  settings.validate();
  WindowAgreement out;
  // A parameter's reference needs the variance of each window's t^2, which exists above 4 cells:
  // a window whose covariance rests on fewer (one strong harmonic carrying its sandwich) is left
  // out, and the text says so.
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
  const EstimateComparison c = compare_estimates(ok);
  if (!c.assessed) {
    out.text = "not assessed: " + c.unusable;
    return out;
  }
  out.assessed = true;
  out.parameters = c.parameters;
  out.joint_chi2 = c.joint_chi2;
  out.joint_dof = c.joint_dof;
  out.joint_expected_chi2 = c.joint_expected_chi2;
  out.joint_p_value = c.joint_p_value;
  out.joint_tested = c.joint_tested;
  out.agree = !c.significant(settings.significance);
  out.text = agreement_text(out, c, too_few_cells);
  return out;
}

}  // namespace magnetometer_insitu_calibration
