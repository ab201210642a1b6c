// record_file_follower's settings, each declared once (common/setting_declaration.hpp): its
// private parameters, their units, defaults, ranges and help. config/record_file_follower.yaml
// and the node's table in docs/nodes.md are printed from this list.
#pragma once

#include "magnetometer_insitu_calibration/common/setting_declaration.hpp"

namespace magnetometer_insitu_calibration {

/// record_file_follower's parameters.
const SettingDeclarations& record_file_follower_setting_declarations();

}  // namespace magnetometer_insitu_calibration
