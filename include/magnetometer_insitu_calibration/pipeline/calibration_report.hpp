// Reports of a pair calibration: the JSON document of calibrate_records --json and the table
// printed on the terminal.
#pragma once

#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"

#include <nlohmann/json.hpp>

#include <string>

namespace magnetometer_insitu_calibration {

/// Names of the two inputs, for the report.
struct ReportInputs {
  std::string reference;  ///< file, bag topic, ...
  std::string test;
};

/// {"settings": {...}, "preprocessing": {...}, "windows": [...]}; per window: start, end (ISO
/// 8601 UTC), samples, harmonics [m0, m], matrix (3x3 rows, T = R n), matrix_stderr,
/// matrix_covariance (9x9, row-major vec(n)), trend_nT_per_day, scale_ratio(_ci95),
/// nonorthogonality_deg {xy, xz, yz} (and _ci95_deg), misalignment_deg(_ci95_deg) [x, y, z],
/// axis_deviation_deg(_ci95_deg), condition_number, coherence, residual_rms_nT, quality,
/// quality_text. *_ci95 are half-widths of 95 % intervals. NaN is written as null.
nlohmann::json window_to_json(const CalibrationWindow& window);
/// {"assessed", "agree", "windows", "joint_chi2", "joint_dof", "joint_expected_chi2",
/// "joint_p_value", "joint_tested", "parameters": {"scale x": {"weighted_mean", "chi2", "expected_chi2",
/// "sqrt_chi2_per_dof" (sqrt(chi2 / expected_chi2)), "p_value"}, ...}, "text"} of the
/// disjoint windows (disjoint_window_estimates, window_agreement.hpp); null when there are none
/// (one window, or overlapping sliding windows). The document's key "window_agreement".
nlohmann::json window_agreement_to_json(const std::vector<CalibrationWindow>& windows);
nlohmann::json calibration_to_json(const PairCalibration& calibration, const CalibrationSettings& settings,
                                   const ReportInputs& inputs);

/// Human-readable table: parameters as rows and windows as columns (up to 6 windows), or one
/// line per window for longer layouts.
std::string format_calibration_table(const PairCalibration& calibration, const ReportInputs& inputs);

}  // namespace magnetometer_insitu_calibration
