// Constants several core test files use. The files of a concern are compiled as one translation
// unit (CMakeLists.txt), so a file names these with a using-declaration instead of defining its own.
#pragma once

#include <limits>

namespace magnetometer_insitu_calibration::test {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kRad = kPi / 180.0;  ///< radians per degree
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
inline constexpr double kMay14 = 1747180800.0;  ///< 2025-05-14T00:00:00Z, Unix s (the WIC day)
inline constexpr double kT0 = 1709642096.0;     ///< 2024-03-05 12:34:56 UTC, Unix s (LEMI test packets)

}  // namespace magnetometer_insitu_calibration::test
