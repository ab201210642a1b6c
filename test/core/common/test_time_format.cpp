// ISO 8601 <-> UNIX seconds: known epochs (truth from Python's calendar.timegm), leap-year
// rules, rounding with carry, and an independent day-by-day walk of the calendar.
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

namespace mic = magnetometer_insitu_calibration;

TEST(ParseIso8601, KnownEpochs) {
  EXPECT_EQ(mic::parse_iso8601("1970-01-01T00:00:00Z"), 0.0);
  EXPECT_EQ(mic::parse_iso8601("1969-12-31T23:59:59Z"), -1.0);
  EXPECT_EQ(mic::parse_iso8601("2000-01-01T00:00:00Z"), 946684800.0);
  EXPECT_EQ(mic::parse_iso8601("2024-02-29T00:00:00Z"), 1709164800.0);
  EXPECT_EQ(mic::parse_iso8601("2025-05-14T00:00:00Z"), 1747180800.0);
  EXPECT_EQ(mic::parse_iso8601("2038-01-19T03:14:08Z"), 2147483648.0);  // 2^31: past int32
  EXPECT_EQ(mic::parse_iso8601("2100-03-01T00:00:00Z"), 4107542400.0);
  EXPECT_EQ(mic::parse_iso8601("1900-03-01T00:00:00Z"), -2203891200.0);
  EXPECT_EQ(mic::parse_iso8601("1600-02-29T12:00:00Z"), -11670955200.0);
  EXPECT_EQ(mic::parse_iso8601("9999-12-31T23:59:59Z"), 253402300799.0);
}

TEST(ParseIso8601, AcceptedSpellingsAgree) {
  const double t = 1747180800.0 + 3600.0 * 13 + 60.0 * 7 + 5.0;  // 2025-05-14 13:07:05
  EXPECT_EQ(mic::parse_iso8601("2025-05-14T13:07:05Z"), t);
  EXPECT_EQ(mic::parse_iso8601("2025-05-14T13:07:05"), t);
  EXPECT_EQ(mic::parse_iso8601("2025-05-14 13:07:05"), t);
  EXPECT_EQ(mic::parse_iso8601("2025-05-14T13:07:05+00:00"), t);
  EXPECT_EQ(mic::parse_iso8601("2025-05-14T13:07:05+0000"), t);
  EXPECT_EQ(mic::parse_iso8601("2025-05-14T13:07:05.000Z"), t);
  // Offsets from UTC: local time minus the offset.
  EXPECT_EQ(mic::parse_iso8601("2025-05-14T15:07:05+02:00"), t);
  EXPECT_EQ(mic::parse_iso8601("2025-05-14T15:07:05+0200"), t);
  EXPECT_EQ(mic::parse_iso8601("2025-05-14T15:07:05+02"), t);
  EXPECT_EQ(mic::parse_iso8601("2025-05-14T07:37:05-05:30"), t);
  EXPECT_EQ(mic::parse_iso8601("2025-05-15T00:07:05.25+11:00"), t + 0.25);  // across midnight
  EXPECT_EQ(mic::parse_iso8601("1970-01-01T00:00:00-01:00"), 3600.0);
}

TEST(ParseIso8601, FractionalSeconds) {
  EXPECT_EQ(mic::parse_iso8601("2025-05-14 00:00:00.123"), 1747180800.123);
  EXPECT_EQ(mic::parse_iso8601("2025-05-14T00:00:00.5Z"), 1747180800.5);
  EXPECT_EQ(mic::parse_iso8601("1970-01-01T00:00:00.000001Z"), 1e-6);
  EXPECT_EQ(mic::parse_iso8601("1969-12-31T23:59:59.25Z"), -0.75);
  EXPECT_EQ(mic::parse_iso8601("1970-01-01T00:00:01.123456789Z"), 1.123456789);
}

TEST(ParseIso8601, RejectsWithTheTextInTheMessage) {
  const char* bad[] = {
      "2025-05-14T00:00:00-00:00",  // RFC 3339's unknown offset
      "2025-05-14T00:00:00-0000",
      "2025-05-14T00:00:00+24:00",  // offsets out of range or malformed
      "2025-05-14T00:00:00+01:60",
      "2025-05-14T00:00:00+1:00",
      "2025-05-14T00:00:00+01:0",
      "2025-05-14T00:00:00+01-00",
      "2025-05-14T00:00:00+010",
      "2025-05-14T00:00:00 +01:00",
      "2025-05-14T00:00:00+01:00Z",
      "2025-05-14T00:00:00UTC",
      "2025-02-29T00:00:00Z",       // 2025 is not a leap year
      "1900-02-29T00:00:00Z",       // century not divisible by 400
      "2025-13-01T00:00:00Z",
      "2025-00-10T00:00:00Z",
      "2025-04-31T00:00:00Z",
      "2025-05-14T24:00:00Z",
      "2025-05-14T12:60:00Z",
      "2025-05-14T12:00:60Z",       // leap second: not a UNIX time
      "2025-05-14",
      "2025-05-14T12:00",
      "2025-05-14T12:00:00.",
      "2025-05-14T12:00:00.5 Z",
      "25-05-14T12:00:00Z",
      " 2025-05-14T12:00:00Z",
      "yesterday",
      "",
  };
  for (const char* text : bad) {
    try {
      mic::parse_iso8601(text);
      ADD_FAILURE() << "accepted '" << text << "'";
    } catch (const std::invalid_argument& error) {
      EXPECT_NE(std::string(error.what()).find("'" + std::string(text) + "'"), std::string::npos)
          << error.what();
    }
  }
}

TEST(FormatIso8601, KnownTexts) {
  EXPECT_EQ(mic::format_iso8601(0.0), "1970-01-01T00:00:00.000Z");
  EXPECT_EQ(mic::format_iso8601(1747180800.0), "2025-05-14T00:00:00.000Z");
  EXPECT_EQ(mic::format_iso8601(1747180800.0, 0), "2025-05-14T00:00:00Z");
  EXPECT_EQ(mic::format_iso8601(1747180800.25, 6), "2025-05-14T00:00:00.250000Z");
  EXPECT_EQ(mic::format_iso8601(1709164800.0 + 86399.0, 0), "2024-02-29T23:59:59Z");
  EXPECT_EQ(mic::format_iso8601(2147483648.0), "2038-01-19T03:14:08.000Z");
  EXPECT_EQ(mic::format_iso8601(4107542400.0 - 1.0, 0), "2100-02-28T23:59:59Z");  // no Feb 29
  EXPECT_EQ(mic::format_iso8601(-0.5), "1969-12-31T23:59:59.500Z");
  EXPECT_EQ(mic::format_iso8601(-11670955200.0, 1), "1600-02-29T12:00:00.0Z");
  EXPECT_EQ(mic::format_iso8601(253402300799.0, 0), "9999-12-31T23:59:59Z");
}

TEST(FormatIso8601, RoundsAndCarries) {
  const double t0 = 1747180800.0;  // 2025-05-14T00:00:00Z
  EXPECT_EQ(mic::format_iso8601(t0 + 59.9996), "2025-05-14T00:01:00.000Z");
  EXPECT_EQ(mic::format_iso8601(t0 + 59.9994), "2025-05-14T00:00:59.999Z");
  EXPECT_EQ(mic::format_iso8601(t0 + 59.9996, 4), "2025-05-14T00:00:59.9996Z");
  EXPECT_EQ(mic::format_iso8601(t0 + 59.6, 0), "2025-05-14T00:01:00Z");
  EXPECT_EQ(mic::format_iso8601(t0 + 59.4, 0), "2025-05-14T00:00:59Z");
  // Carry through hour, day, month and year.
  const double new_year = 1735689600.0;  // 2025-01-01T00:00:00Z
  EXPECT_EQ(mic::format_iso8601(new_year - 0.0004), "2025-01-01T00:00:00.000Z");
  EXPECT_EQ(mic::format_iso8601(new_year - 0.0006), "2024-12-31T23:59:59.999Z");
  EXPECT_EQ(mic::format_iso8601(-0.0001), "1970-01-01T00:00:00.000Z");
}

TEST(FormatIso8601, RejectsBadArguments) {
  EXPECT_THROW(mic::format_iso8601(std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
  EXPECT_THROW(mic::format_iso8601(std::numeric_limits<double>::infinity()), std::invalid_argument);
  EXPECT_THROW(mic::format_iso8601(0.0, -1), std::invalid_argument);
  EXPECT_THROW(mic::format_iso8601(0.0, 10), std::invalid_argument);
  EXPECT_THROW(mic::format_iso8601(253402300800.0), std::invalid_argument);  // year 10000
}

TEST(FormatIso8601, RoundTripsMillisecondTimes) {
  // Millisecond times from 1965 to 2110, about 5 per day, at varying millisecond offsets.
  const double start = mic::parse_iso8601("1965-01-01T00:00:00Z");
  const double stop = mic::parse_iso8601("2110-01-01T00:00:00Z");
  int checked = 0;
  for (double t = start; t < stop; t += 17321.123) {
    const double ms = std::round(t * 1000.0) / 1000.0;
    const std::string text = mic::format_iso8601(ms, 3);
    ASSERT_EQ(mic::parse_iso8601(text), ms) << text;
    ++checked;
  }
  EXPECT_GT(checked, 250000);
}

// Independent truth: walk the calendar one day at a time with the month-length table.
TEST(CivilDays, AgreesWithDayByDayWalk) {
  std::int64_t year = 1970;
  int month = 1;
  int day = 1;
  for (std::int64_t days = 0; days < 60000; ++days) {  // 1970 .. 2134
    ASSERT_EQ(mic::days_from_civil(year, month, day), days);
    std::int64_t y = 0;
    int m = 0;
    int d = 0;
    mic::civil_from_days(days, y, m, d);
    ASSERT_EQ(y, year);
    ASSERT_EQ(m, month);
    ASSERT_EQ(d, day);
    if (++day > mic::days_in_month(year, month)) {
      day = 1;
      if (++month > 12) {
        month = 1;
        ++year;
      }
    }
  }
  year = 1970, month = 1, day = 1;
  for (std::int64_t days = 0; days > -30000; --days) {  // back to 1887
    ASSERT_EQ(mic::days_from_civil(year, month, day), days);
    if (--day < 1) {
      if (--month < 1) {
        month = 12;
        --year;
      }
      day = mic::days_in_month(year, month);
    }
  }
}

TEST(CivilDays, LeapYearRules) {
  EXPECT_TRUE(mic::is_leap_year(2000));
  EXPECT_TRUE(mic::is_leap_year(2024));
  EXPECT_FALSE(mic::is_leap_year(1900));
  EXPECT_FALSE(mic::is_leap_year(2100));
  EXPECT_FALSE(mic::is_leap_year(2025));
  EXPECT_EQ(mic::days_from_civil(2001, 1, 1) - mic::days_from_civil(2000, 1, 1), 366);
  EXPECT_EQ(mic::days_from_civil(1901, 1, 1) - mic::days_from_civil(1900, 1, 1), 365);
  EXPECT_EQ(mic::days_from_civil(2101, 1, 1) - mic::days_from_civil(2100, 1, 1), 365);
  EXPECT_EQ(mic::days_from_civil(2400, 1, 1) - mic::days_from_civil(2000, 1, 1), 146097);
}
