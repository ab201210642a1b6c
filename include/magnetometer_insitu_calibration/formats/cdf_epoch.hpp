// CDF time types and UTC: CDF_EPOCH (ms since 0000-01-01, no leap seconds), CDF_EPOCH16 and
// CDF_TIME_TT2000 (ns since J2000 = 2000-01-01T12:00:00 TT, leap seconds counted).
#pragma once

#include <cstdint>

namespace magnetometer_insitu_calibration {

/// TAI - UTC in seconds at UNIX time `unix_s` (UTC), from the leap-second table (IERS Bulletin C:
/// 10 s at 1972-01-01 ... 37 s since 2017-01-01; no leap second announced up to the table's
/// end). Before 1972 there is no integral offset: returns -1.
int tai_minus_utc_s(double unix_s);

enum class Tt2000Status {
  kOk,
  kLeapSecond,  ///< inside a positive leap second (23:59:60.xxx): no UNIX time exists for it
  kBefore1972,  ///< before 1972-01-01 UTC (rubber seconds): not supported
  kTooLate,     ///< after the year 2262 (beyond the int64 nanosecond range in UNIX time)
  kFill,        ///< the fill value -9223372036854775808 or the pad value -9223372036854775807
};

/// TT2000 nanoseconds -> UNIX seconds (UTC). unix_s is set only for kOk; whole seconds are exact.
Tt2000Status tt2000_to_unix(std::int64_t tt2000_ns, double& unix_s);

/// UNIX seconds (UTC, from 1972) -> TT2000 nanoseconds, rounded to the nanosecond.
std::int64_t unix_to_tt2000(double unix_s);

/// CDF_EPOCH milliseconds -> UNIX seconds (both without leap seconds).
double cdf_epoch_to_unix(double epoch_ms);

/// Seconds from 0000-01-01T00:00:00 to 1970-01-01T00:00:00 (proleptic Gregorian calendar).
constexpr double kCdfEpochUnixOffset_s = 62167219200.0;

}  // namespace magnetometer_insitu_calibration
