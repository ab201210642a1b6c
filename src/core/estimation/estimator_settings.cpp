// Names, parsing and validation of the estimator settings declared in fd_wlse.hpp (method,
// errors-in-variables mode, RobustSettings).
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"

#include "magnetometer_insitu_calibration/estimation/band_selection.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <cmath>
#include <string>

namespace magnetometer_insitu_calibration {

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

bool RobustSettings::reference_noise_identified() const {
  return eiv == EivCorrection::kGiven &&
         ((reference_white_nT.array() > 0.0).any() || (reference_pink_nT_per_sqrt_hz.array() > 0.0).any());
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
  for (const Eigen::Matrix2d& c : reference_noise_level_covariance) {
    if (!c.allFinite() || c(0, 0) < 0.0 || c(1, 1) < 0.0 || std::abs(c(0, 1) - c(1, 0)) > 1e-12 * c.cwiseAbs().maxCoeff() ||
        c(0, 1) * c(0, 1) > c(0, 0) * c(1, 1) * (1.0 + 1e-9))
      throw InputError("reference_noise_level_covariance", "must be a finite symmetric positive semi-definite 2 x 2 per axis");
  }
}


}  // namespace magnetometer_insitu_calibration
