// The user's settings of the calibration and the correction, each declared once
// (setting_declaration.hpp): calibration_node's private parameters and calibrate_records'
// options share the declarations of what both set. The documents (config/*.yaml, the tables of
// docs/nodes.md and docs/programs.md) are printed from these lists by print_settings.
#pragma once

#include "magnetometer_insitu_calibration/common/setting_bindings.hpp"
#include "magnetometer_insitu_calibration/common/setting_declaration.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/pipeline/window_calibration.hpp"

namespace magnetometer_insitu_calibration {

/// The calibration's settings: calibration_node's parameters (those with a `parameter`) and
/// calibrate_records' options (those with an `option`), in the documents' order.
const SettingDeclarations& calibration_setting_declarations();

/// correction_node's parameters.
const SettingDeclarations& correction_setting_declarations();

/// The per-window stage's settings (estimator, robust steps, noise, response model, gap and
/// temperature rules) bound to WindowCalibrationSettings: shared by the node and the program.
/// The figure ~reference_noise_pT / --reference-noise-pT sets reference_noise_figure; the
/// choices ~method and ~eiv set the enum and the flag.
const SettingBindings<WindowCalibrationSettings>& window_calibration_bindings();

/// calibrate_records' settings bound to CalibrationSettings: the window stage's, the pairing,
/// the epochs and the layout. The tolerance file (a file to read) is bound by the program.
const SettingBindings<CalibrationSettings>& calibration_settings_bindings();

}  // namespace magnetometer_insitu_calibration
