// Private to the pipeline's JSON writers: a number as JSON, or null where it is not finite (JSON has
// no NaN or infinity; a reader sees null as "not estimated").
#pragma once

#include <nlohmann/json.hpp>

#include <cmath>

namespace magnetometer_insitu_calibration::json_detail {

inline nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

}  // namespace magnetometer_insitu_calibration::json_detail
