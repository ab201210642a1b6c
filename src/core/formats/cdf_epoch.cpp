// CDF time conversions; see cdf_epoch.hpp.
#include "magnetometer_insitu_calibration/formats/cdf_epoch.hpp"

#include <cmath>
#include <iterator>
#include <limits>

namespace magnetometer_insitu_calibration {

namespace {

struct LeapStep {
  std::int64_t unix_s;  ///< UTC instant from which the offset applies
  int tai_minus_utc_s;
};

// IERS Bulletin C: TAI - UTC from each date on (UNIX seconds of 00:00:00 UTC that day).
constexpr LeapStep kLeapSeconds[] = {
    {63072000, 10},   // 1972-01-01
    {78796800, 11},   // 1972-07-01
    {94694400, 12},   // 1973-01-01
    {126230400, 13},  // 1974-01-01
    {157766400, 14},  // 1975-01-01
    {189302400, 15},  // 1976-01-01
    {220924800, 16},  // 1977-01-01
    {252460800, 17},  // 1978-01-01
    {283996800, 18},  // 1979-01-01
    {315532800, 19},  // 1980-01-01
    {362793600, 20},  // 1981-07-01
    {394329600, 21},  // 1982-07-01
    {425865600, 22},  // 1983-07-01
    {489024000, 23},  // 1985-07-01
    {567993600, 24},  // 1988-01-01
    {631152000, 25},  // 1990-01-01
    {662688000, 26},  // 1991-01-01
    {709948800, 27},  // 1992-07-01
    {741484800, 28},  // 1993-07-01
    {773020800, 29},  // 1994-07-01
    {820454400, 30},  // 1996-01-01
    {867715200, 31},  // 1997-07-01
    {915148800, 32},  // 1999-01-01
    {1136073600, 33},  // 2006-01-01
    {1230768000, 34},  // 2009-01-01
    {1341100800, 35},  // 2012-07-01
    {1435708800, 36},  // 2015-07-01
    {1483228800, 37},  // 2017-01-01
};

constexpr std::int64_t kNs = 1000000000;
// TT2000 = 0 is 2000-01-01T12:00:00 TT = 11:59:27.816 TAI; as TAI calendar seconds since 1970:
constexpr std::int64_t kJ2000TaiNs = 946727967816000000;

}  // namespace

int tai_minus_utc_s(double unix_s) {
  int offset = -1;
  for (const LeapStep& s : kLeapSeconds) {
    if (unix_s >= static_cast<double>(s.unix_s)) offset = s.tai_minus_utc_s;
  }
  return offset;
}

Tt2000Status tt2000_to_unix(std::int64_t tt2000_ns, double& unix_s) {
  if (tt2000_ns <= std::numeric_limits<std::int64_t>::min() + 1) return Tt2000Status::kFill;
  if (tt2000_ns > std::numeric_limits<std::int64_t>::max() - kJ2000TaiNs) return Tt2000Status::kTooLate;
  const std::int64_t tai_ns = tt2000_ns + kJ2000TaiNs;  // TAI as calendar nanoseconds since 1970
  // The step in force: the last whose start, in TAI, is not after tai_ns.
  const LeapStep* step = nullptr;
  for (const LeapStep& s : kLeapSeconds) {
    if (tai_ns >= (s.unix_s + s.tai_minus_utc_s) * kNs) step = &s;
  }
  if (step == nullptr) return Tt2000Status::kBefore1972;
  const LeapStep* next = step + 1;
  // The second before the next step starts in TAI is the inserted second 23:59:60.
  if (next != std::end(kLeapSeconds) && tai_ns >= (next->unix_s + next->tai_minus_utc_s - 1) * kNs) {
    return Tt2000Status::kLeapSecond;
  }
  const std::int64_t utc_ns = tai_ns - step->tai_minus_utc_s * kNs;
  std::int64_t seconds = utc_ns / kNs, rest = utc_ns % kNs;
  if (rest < 0) rest += kNs, seconds -= 1;
  unix_s = static_cast<double>(seconds) + static_cast<double>(rest) * 1e-9;
  return Tt2000Status::kOk;
}

std::int64_t unix_to_tt2000(double unix_s) {
  double whole = std::floor(unix_s);
  std::int64_t fraction_ns = std::llround((unix_s - whole) * 1e9);
  if (fraction_ns >= kNs) fraction_ns -= kNs, whole += 1;
  const auto seconds = static_cast<std::int64_t>(whole);
  const int offset = tai_minus_utc_s(static_cast<double>(seconds));
  return (seconds + offset) * kNs + fraction_ns - kJ2000TaiNs;
}

double cdf_epoch_to_unix(double epoch_ms) { return epoch_ms / 1000.0 - kCdfEpochUnixOffset_s; }

}  // namespace magnetometer_insitu_calibration
