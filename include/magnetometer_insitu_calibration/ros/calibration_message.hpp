// The MagnetometerCalibration message of a window's calibration record: field by field from the
// table of pipeline/calibration_record.hpp (the message has exactly its fields, in its order,
// plus the header). Times: UNIX seconds and nanoseconds, as the record keeps them.
#pragma once

#include "magnetometer_insitu_calibration/pipeline/calibration_record.hpp"
#include "magnetometer_insitu_calibration/pipeline/tolerance_verdicts.hpp"

#include <magnetometer_insitu_calibration/MagnetometerCalibration.h>

namespace magnetometer_insitu_calibration {

static_assert(static_cast<int>(Quality::kOk) == MagnetometerCalibration::QUALITY_OK &&
                  static_cast<int>(Quality::kTooFewSamples) == MagnetometerCalibration::QUALITY_TOO_FEW_SAMPLES &&
                  static_cast<int>(Quality::kTooFewHarmonics) == MagnetometerCalibration::QUALITY_TOO_FEW_HARMONICS &&
                  static_cast<int>(Quality::kIllConditioned) == MagnetometerCalibration::QUALITY_ILL_CONDITIONED &&
                  static_cast<int>(Quality::kLowCoherence) == MagnetometerCalibration::QUALITY_LOW_COHERENCE &&
                  static_cast<int>(Quality::kGaps) == MagnetometerCalibration::QUALITY_GAPS &&
                  static_cast<int>(Quality::kNotFinite) == MagnetometerCalibration::QUALITY_NOT_FINITE,
              "Quality and the message's QUALITY_* constants must agree");

/// The message of a record (header.stamp = record.stamp, header.frame_id = record.frame_id).
/// Throws std::out_of_range when a time does not fit ROS time (before 1970 or after 2106).
MagnetometerCalibration to_message(const CalibrationRecord& record);

/// The message's verdicts (beyond the record) from a window's.
void set_verdicts(MagnetometerCalibration& message, const std::vector<ToleranceVerdict>& verdicts);

/// A record time as ROS time; throws std::out_of_range naming `field` when it does not fit.
ros::Time to_ros_time(const RecordTime& time, const char* field);

}  // namespace magnetometer_insitu_calibration
