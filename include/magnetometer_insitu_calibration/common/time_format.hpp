// ISO 8601 <-> UNIX seconds for UTC times, by civil-calendar arithmetic (no timegm, no locale).
#pragma once

#include <cstdint>
#include <string>

namespace magnetometer_insitu_calibration {

/// Parses an ISO 8601 time to UNIX seconds (leap seconds not counted). Accepts
/// "YYYY-MM-DDThh:mm:ss" or "YYYY-MM-DD hh:mm:ss", optional fractional seconds of any length
/// (".123", ".123456789"), an optional zone: none or "Z" (UTC), or an offset from UTC "+hh:mm",
/// "+hhmm", "+hh" or with "-" ("2025-05-14T02:00:00+02:00" is 00:00 UTC).
/// Throws std::invalid_argument whose message quotes the text, for anything else, including
/// "-00:00" (an unknown offset) and impossible dates or times (2025-02-29, 24:00:00, second 60).
double parse_iso8601(const std::string& text);

/// Formats UNIX seconds as "YYYY-MM-DDThh:mm:ss.fffZ" with `decimals` (0..9) fractional digits,
/// no dot when decimals == 0. Rounds to nearest at that precision and carries into seconds,
/// minutes, days and years (59.9996 s with 3 decimals becomes the next minute).
/// Throws std::invalid_argument for a non-finite time, decimals outside 0..9, or a year outside
/// 0000..9999.
std::string format_iso8601(double unix_s, int decimals = 3);

/// A time for an error message: ISO 8601 when it has one (years 0000..9999 after rounding to
/// the millisecond), else "<seconds> s (UNIX time)". Never throws, so an InputError being built
/// is not replaced by format_iso8601's std::invalid_argument (found by fuzzing the readers).
std::string time_for_message(double unix_s);

/// Days since 1970-01-01 of a proleptic Gregorian date (month 1..12, day 1..31); no range checks.
std::int64_t days_from_civil(std::int64_t year, int month, int day);

/// Proleptic Gregorian date of a day number counted from 1970-01-01.
void civil_from_days(std::int64_t days, std::int64_t& year, int& month, int& day);

/// True for Gregorian leap years.
bool is_leap_year(std::int64_t year);

/// Number of days in a month (1..12) of a year.
int days_in_month(std::int64_t year, int month);

}  // namespace magnetometer_insitu_calibration
