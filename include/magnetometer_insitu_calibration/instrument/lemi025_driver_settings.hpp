// The LEMI-025 driver's settings, each declared once (common/setting_declaration.hpp): its
// private parameters, their units, defaults, ranges and help. config/lemi025_driver.yaml and the
// driver's table in docs/nodes.md are printed from this list.
#pragma once

#include "magnetometer_insitu_calibration/common/setting_declaration.hpp"

namespace magnetometer_insitu_calibration {

/// lemi025_driver's parameters.
const SettingDeclarations& lemi025_driver_setting_declarations();

}  // namespace magnetometer_insitu_calibration
