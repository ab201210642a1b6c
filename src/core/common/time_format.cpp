// ISO 8601 <-> UNIX seconds (UTC) by civil-calendar arithmetic; see time_format.hpp.
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

namespace magnetometer_insitu_calibration {

namespace {

constexpr std::int64_t kSecondsPerDay = 86400;

[[noreturn]] void reject(const std::string& text, const std::string& why) {
  throw std::invalid_argument("invalid ISO 8601 UTC time '" + text + "': " + why);
}

bool is_digit(char c) { return c >= '0' && c <= '9'; }

/// Reads `count` digits at `pos` as a non-negative integer, or rejects the text.
int digits_at(const std::string& text, std::size_t pos, int count, const char* field) {
  int value = 0;
  for (int i = 0; i < count; ++i) {
    if (pos + i >= text.size() || !is_digit(text[pos + i])) {
      reject(text, std::string("expected ") + std::to_string(count) + " digits for the " + field);
    }
    value = value * 10 + (text[pos + i] - '0');
  }
  return value;
}

void expect_char(const std::string& text, std::size_t pos, const char* allowed, const char* what) {
  if (pos >= text.size()) reject(text, std::string("ends before ") + what);
  for (const char* a = allowed; *a != '\0'; ++a) {
    if (text[pos] == *a) return;
  }
  reject(text, std::string("expected ") + what + " at character " + std::to_string(pos + 1));
}

std::int64_t floor_div(std::int64_t a, std::int64_t b) {
  std::int64_t q = a / b;
  if ((a % b != 0) && ((a < 0) != (b < 0))) --q;
  return q;
}

}  // namespace

bool is_leap_year(std::int64_t year) {
  return (year % 4 == 0 && year % 100 != 0) || year % 400 == 0;
}

int days_in_month(std::int64_t year, int month) {
  static const int kDays[12] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  if (month == 2 && is_leap_year(year)) return 29;
  return kDays[month - 1];
}

// Day counting in 400-year eras of 146097 days, the year taken to start on 1 March so that the
// leap day is the last day of the year (the well-known "days from civil" construction).
std::int64_t days_from_civil(std::int64_t year, int month, int day) {
  const std::int64_t y = month <= 2 ? year - 1 : year;
  const std::int64_t era = floor_div(y, 400);
  const std::int64_t year_of_era = y - era * 400;                          // 0..399
  const std::int64_t month_from_march = month > 2 ? month - 3 : month + 9;  // 0..11
  const std::int64_t day_of_year = (153 * month_from_march + 2) / 5 + day - 1;  // 0..365
  const std::int64_t day_of_era =
      year_of_era * 365 + year_of_era / 4 - year_of_era / 100 + day_of_year;  // 0..146096
  return era * 146097 + day_of_era - 719468;  // 719468 = days from 0000-03-01 to 1970-01-01
}

void civil_from_days(std::int64_t days, std::int64_t& year, int& month, int& day) {
  const std::int64_t z = days + 719468;
  const std::int64_t era = floor_div(z, 146097);
  const std::int64_t day_of_era = z - era * 146097;  // 0..146096
  const std::int64_t year_of_era =
      (day_of_era - day_of_era / 1460 + day_of_era / 36524 - day_of_era / 146096) / 365;
  const std::int64_t day_of_year =
      day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);  // 0..365
  const std::int64_t month_from_march = (5 * day_of_year + 2) / 153;            // 0..11
  day = static_cast<int>(day_of_year - (153 * month_from_march + 2) / 5 + 1);
  month = static_cast<int>(month_from_march < 10 ? month_from_march + 3 : month_from_march - 9);
  year = year_of_era + era * 400 + (month <= 2 ? 1 : 0);
}

/// The zone designator from `pos` to the end of `text`, as seconds east of UTC: none, "Z" or an
/// ISO 8601 offset "+hh:mm", "+hhmm" or "+hh" (or "-"; hh <= 23, mm <= 59). "-00:00", which
/// RFC 3339 uses for "offset unknown", is refused.
std::int64_t zone_offset_s(const std::string& text, std::size_t pos) {
  const std::string zone = text.substr(pos);
  if (zone.empty() || zone == "Z" || zone == "z") return 0;
  const auto fail = [&] {
    reject(text, "unsupported suffix '" + zone + "' (a zone is 'Z' or an offset +hh:mm, +hhmm or +hh)");
  };
  const bool colon = zone.size() == 6 && zone[3] == ':';
  if ((zone[0] != '+' && zone[0] != '-') || !(zone.size() == 3 || zone.size() == 5 || colon)) fail();
  for (std::size_t i = 1; i < zone.size(); ++i) {
    if (!(is_digit(zone[i]) || (colon && i == 3))) fail();
  }
  const int hours = (zone[1] - '0') * 10 + (zone[2] - '0');
  const std::size_t m = colon ? 4 : 3;
  const int minutes = zone.size() > 3 ? (zone[m] - '0') * 10 + (zone[m + 1] - '0') : 0;
  if (hours > 23 || minutes > 59) reject(text, "zone offset '" + zone + "' out of range (at most 23:59)");
  if (zone[0] == '-' && hours == 0 && minutes == 0) {
    reject(text, "zone offset '" + zone + "' means an unknown offset (RFC 3339); UTC is 'Z'");
  }
  return (zone[0] == '-' ? -1 : 1) * (hours * 3600 + minutes * 60);
}

double parse_iso8601(const std::string& text) {
  // Fixed part: YYYY-MM-DD?hh:mm:ss (19 characters).
  const int year = digits_at(text, 0, 4, "year");
  expect_char(text, 4, "-", "'-' after the year");
  const int month = digits_at(text, 5, 2, "month");
  expect_char(text, 7, "-", "'-' after the month");
  const int day = digits_at(text, 8, 2, "day");
  expect_char(text, 10, "T ", "'T' or ' ' between date and time");
  const int hour = digits_at(text, 11, 2, "hour");
  expect_char(text, 13, ":", "':' after the hour");
  const int minute = digits_at(text, 14, 2, "minute");
  expect_char(text, 16, ":", "':' after the minute");
  const int second = digits_at(text, 17, 2, "second");

  if (month < 1 || month > 12) reject(text, "month out of range 01..12");
  if (day < 1 || day > days_in_month(year, month)) {
    reject(text, "day out of range for " + std::to_string(year) + "-" + std::to_string(month));
  }
  if (hour > 23) reject(text, "hour out of range 00..23");
  if (minute > 59) reject(text, "minute out of range 00..59");
  if (second > 59) reject(text, "second out of range 00..59 (leap seconds are not representable)");

  std::size_t pos = 19;
  double fraction = 0.0;
  if (pos < text.size() && text[pos] == '.') {
    std::size_t end = pos + 1;
    while (end < text.size() && is_digit(text[end])) ++end;
    if (end == pos + 1) reject(text, "no digits after the decimal point");
    // "0.ddd" parsed by strtod is the double nearest to the decimal fraction.
    fraction = std::strtod(("0" + text.substr(pos, end - pos)).c_str(), nullptr);
    pos = end;
  }
  const std::int64_t whole = days_from_civil(year, month, day) * kSecondsPerDay +
                             hour * 3600 + minute * 60 + second;
  return static_cast<double>(whole - zone_offset_s(text, pos)) + fraction;
}

std::string format_iso8601(double unix_s, int decimals) {
  if (!std::isfinite(unix_s)) throw std::invalid_argument("format_iso8601: time is not finite");
  if (decimals < 0 || decimals > 9) {
    throw std::invalid_argument("format_iso8601: decimals " + std::to_string(decimals) +
                                " outside 0..9");
  }
  const double floor_s = std::floor(unix_s);
  if (std::fabs(floor_s) > 4.0e11) {
    throw std::invalid_argument("format_iso8601: time " + std::to_string(unix_s) +
                                " s is outside years 0000..9999");
  }
  std::int64_t whole = static_cast<std::int64_t>(floor_s);
  const double fraction = unix_s - floor_s;  // exact, in [0, 1)
  std::int64_t scale = 1;
  for (int i = 0; i < decimals; ++i) scale *= 10;
  std::int64_t units = std::llround(fraction * static_cast<double>(scale));
  if (units >= scale) {  // rounding carried into the next second
    whole += 1;
    units -= scale;
  }

  const std::int64_t days = floor_div(whole, kSecondsPerDay);
  const std::int64_t second_of_day = whole - days * kSecondsPerDay;
  std::int64_t year = 0;
  int month = 0;
  int day = 0;
  civil_from_days(days, year, month, day);
  if (year < 0 || year > 9999) {
    throw std::invalid_argument("format_iso8601: year " + std::to_string(year) +
                                " outside 0000..9999");
  }
  char buffer[48];
  int n = std::snprintf(buffer, sizeof buffer, "%04d-%02d-%02dT%02d:%02d:%02d",
                        static_cast<int>(year), month, day,
                        static_cast<int>(second_of_day / 3600),
                        static_cast<int>(second_of_day / 60 % 60),
                        static_cast<int>(second_of_day % 60));
  std::string out(buffer, static_cast<std::size_t>(n));
  if (decimals > 0) {
    n = std::snprintf(buffer, sizeof buffer, ".%0*lld", decimals, static_cast<long long>(units));
    out.append(buffer, static_cast<std::size_t>(n));
  }
  out += 'Z';
  return out;
}

std::string time_for_message(double unix_s) {
  try {
    return format_iso8601(unix_s);
  } catch (const std::invalid_argument&) {
    char buffer[40];
    std::snprintf(buffer, sizeof buffer, "%.17g s (UNIX time)", unix_s);
    return buffer;
  }
}

}  // namespace magnetometer_insitu_calibration
