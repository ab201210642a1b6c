// Reports of a pair calibration: the JSON document of calibrate_records --json and the table
// printed on the terminal.
#pragma once

#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// Names of the two inputs, for the report.
struct ReportInputs {
  std::string reference;  ///< file, bag topic, ...
  std::string test;
  std::string remote;     ///< the remote observatory's record, "" without one
  /// False when the records' component names are not their own (a bag: a MagneticField names
  /// none, its x, y, z being its frame's axes): the report then gives them as null.
  bool components_named = true;
  /// The records' frames when they came from a bag (each topic's header.frame_id): a
  /// MagneticField's instrument identity, which export_corrected checks a bag's test topic
  /// against. Empty for files (written as null).
  std::string reference_frame_id, test_frame_id;
  /// The files as given, one per entry (`reference` and `test` join several with " + ", which a
  /// file name may contain): settings.reference_files / test_files, absent when empty (a bag).
  std::vector<std::string> reference_files, test_files;
};

/// One window of the report: its calibration record (calibration_record.hpp: every field of
/// MIC_CALIBRATION_FIELDS under its own name: test_name "test" and empty frame ids, the inputs being
/// named in the document's settings) and, beyond
/// it, label, matrix_stderr (3 x 3 rows), screened_fraction, downweighted_fraction, eiv (the
/// errors-in-variables text), eiv_applied, reference_noise_source, reference_noise (the
/// identification's line or null), weights, intervals, relative_response (per band) and
/// response_model. *_ci95 are half-widths of 95 % intervals; NaN is written as null.
nlohmann::json window_to_json(const CalibrationWindow& window, const CalibrationSettings& settings);
/// {"assessed", "agree", "windows", "joint_chi2", "joint_dof", "joint_expected_chi2",
/// "joint_p_value", "joint_tested", "parameters": {"scale x": {"weighted_mean", "chi2", "expected_chi2",
/// "sqrt_chi2_per_dof" (sqrt(chi2 / expected_chi2)), "p_value"}, ...}, "text"} of the
/// disjoint windows (disjoint_window_estimates, window_agreement.hpp); null when there are none
/// (one window, or overlapping sliding windows). The document's key "window_agreement".
nlohmann::json window_agreement_to_json(const std::vector<CalibrationWindow>& windows);
/// {"settings": {...}, "preprocessing": {...}, "windows": [window_to_json, ...],
/// "window_agreement": ...}.
nlohmann::json calibration_to_json(const PairCalibration& calibration, const CalibrationSettings& settings,
                                   const ReportInputs& inputs);

/// Human-readable table: parameters as rows and windows as columns (up to 6 windows), or one
/// line per window for longer layouts.
std::string format_calibration_table(const PairCalibration& calibration, const ReportInputs& inputs);

}  // namespace magnetometer_insitu_calibration
