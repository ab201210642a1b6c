// The summary that opens calibrate_records' report: the three questions an observatory
// engineer asks, answered for the window that sums the record up (the whole record in the
// paper's layout, else the last window):
//  1. is each parameter within its tolerance (within / outside / undecided);
//  2. if undecided, how long a record would decide (tolerance_verdicts.hpp);
//  3. what correction to apply, and the command that applies it.
#pragma once

#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"

#include <nlohmann/json.hpp>

#include <string>

namespace magnetometer_insitu_calibration {

/// The window the summary speaks of: the one labelled kWholeRecordLabel, else the last; null
/// when there is none.
const CalibrationWindow* summary_window(const PairCalibration& calibration);

/// Why the window's own checks do not vouch for its pair-only estimate (local events above the
/// band, the band's halves differing by more than the intervals carry; local_event_check.hpp,
/// remote_reference.hpp), in words;
/// empty when they do, or when n rests on a remote. The summary and calibration_node's
/// tolerance status say it beside the verdicts.
std::string not_vouched_for(const WindowEstimate& estimate);

/// The summary's text (ends with a blank line); `tolerances` names where they come from.
std::string format_calibration_summary(const PairCalibration& calibration, const Tolerances& tolerances);

/// A window's "verdicts": [{"parameter", "value", "ci95", "nominal", "tolerance", "verdict",
/// "record_needed_s" (null unless undecided and predictable), "record_needed" (words)}, ...].
nlohmann::json verdicts_to_json(const std::vector<ToleranceVerdict>& verdicts);
/// {"source", "scale" (fractions), "nonorthogonality_deg", "misalignment_deg"}: three values each.
nlohmann::json tolerances_to_json(const Tolerances& tolerances);
/// {"exponent", "exponent_se", "sub_windows", "text"} of a window's IntervalNarrowing.
nlohmann::json narrowing_to_json(const IntervalNarrowing& narrowing);

}  // namespace magnetometer_insitu_calibration
