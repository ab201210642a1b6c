// The tolerance file: a user's own tolerances for the report's verdicts, YAML, e.g. a coil
// laboratory's figures:
//
//   scale_percent: 0.04             # |scale ratio - 1|, percent: one value, or [x, y, z]
//   nonorthogonality_deg: 0.02      # |90 deg - angle between axes|: one value, or [xy, xz, yz]
//   misalignment_deg: 0.02          # rotation-vector components: one value, or [x, y, z]
//
// A key left out keeps the default (INTERMAGNET's 1-second standard, common/tolerances.hpp); an
// unknown key, a value that is not a positive number, or a list not of three is refused with an
// InputError naming the file and the key.
#pragma once

#include "magnetometer_insitu_calibration/common/tolerances.hpp"

#include <string>

namespace magnetometer_insitu_calibration {

Tolerances read_tolerance_file(const std::string& path);

/// The same from the file's text (`name` names it in errors).
Tolerances parse_tolerances(const std::string& text, const std::string& name);

}  // namespace magnetometer_insitu_calibration
