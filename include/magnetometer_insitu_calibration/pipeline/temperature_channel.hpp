// The test record's sensor temperature for the temperature terms of the estimate
// (estimation/temperature_regression.hpp): which auxiliary channel, and its values on the
// estimation grid.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// The channel of `record` to use as its sensor temperature (deg C):
/// - "none": nullptr;
/// - "auto": the first of: a channel named sensor_temperature; one whose description mentions
///   the sensor (e.g. MagPy's t1 "T_sensor") with a degC unit; one named temperature; nullptr
///   when there is none (the record carries no temperature);
/// - any other text: the channel of that exact name; throws InputError(record.source, ...)
///   listing the channels the record has when it is missing.
/// A channel whose values are not one per sample throws InputError(record.source, ...).
const AuxiliaryChannel* find_temperature_channel(const VectorRecord& record, const std::string& name);

/// How interpolate_channel joins two samples: a straight line, or a cubic Hermite curve with
/// centred-difference slopes (Catmull-Rom on a regular record; a straight line where a
/// neighbour beyond the two is missing or more than max_gap_s away). At 0.01 Hz on a 1 s record
/// halfway between samples a straight line loses 0.05 % of the amplitude, the cubic about 1e-7.
enum class ChannelInterpolation { kLinear, kCubic };

/// Interpolation of a channel (times strictly increasing, NaN = missing) at times `at`: NaN
/// outside the finite samples' span and where the two finite neighbours are more than
/// max_gap_s apart.
Eigen::VectorXd interpolate_channel(const std::vector<double>& time_s, const std::vector<double>& values,
                                    const std::vector<double>& at, double max_gap_s,
                                    ChannelInterpolation how = ChannelInterpolation::kLinear);

}  // namespace magnetometer_insitu_calibration
