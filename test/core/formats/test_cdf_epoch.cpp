// CDF time types: TT2000 with the leap-second table (inside a leap second too), CDF_EPOCH.
#include "magnetometer_insitu_calibration/formats/cdf_epoch.hpp"

#include <gtest/gtest.h>

#include <cstdint>

namespace mic = magnetometer_insitu_calibration;

namespace {
constexpr std::int64_t kS = 1000000000;
constexpr double k2017 = 1483228800.0;  // 2017-01-01T00:00:00Z, after the leap second 2016-12-31T23:59:60
}  // namespace

TEST(CdfEpoch, Tt2000DefinitionAndKnownValues) {
  double unix_s = 0;
  // TT2000 = 0 is 2000-01-01T12:00:00 TT = 11:59:27.816 TAI = 11:58:55.816 UTC (TAI - UTC = 32 s).
  ASSERT_EQ(mic::tt2000_to_unix(0, unix_s), mic::Tt2000Status::kOk);
  EXPECT_NEAR(unix_s, 946727935.816, 1e-6);
  // 2017-01-01T00:00:00 UTC: 37 leap seconds, 536500869.184 s after J2000.
  EXPECT_EQ(mic::unix_to_tt2000(k2017), 536500869184000000);
  ASSERT_EQ(mic::tt2000_to_unix(536500869184000000, unix_s), mic::Tt2000Status::kOk);
  EXPECT_EQ(unix_s, k2017);
  EXPECT_EQ(mic::tai_minus_utc_s(k2017 - 1), 36);
  EXPECT_EQ(mic::tai_minus_utc_s(k2017), 37);
  EXPECT_EQ(mic::tai_minus_utc_s(63071999.0), -1);
}

TEST(CdfEpoch, InsideALeapSecondHasNoUnixTime) {
  const std::int64_t midnight = mic::unix_to_tt2000(k2017);
  double unix_s = 0;
  // 23:59:59.000 and .999999999 before the leap second, then 23:59:60.000 to .999999999.
  ASSERT_EQ(mic::tt2000_to_unix(midnight - 2 * kS, unix_s), mic::Tt2000Status::kOk);
  EXPECT_EQ(unix_s, k2017 - 1);
  ASSERT_EQ(mic::tt2000_to_unix(midnight - kS - 1, unix_s), mic::Tt2000Status::kOk);
  EXPECT_NEAR(unix_s, k2017 - 1e-9, 1e-6);
  EXPECT_EQ(mic::tt2000_to_unix(midnight - kS, unix_s), mic::Tt2000Status::kLeapSecond);
  EXPECT_EQ(mic::tt2000_to_unix(midnight - kS / 2, unix_s), mic::Tt2000Status::kLeapSecond);
  EXPECT_EQ(mic::tt2000_to_unix(midnight - 1, unix_s), mic::Tt2000Status::kLeapSecond);
  ASSERT_EQ(mic::tt2000_to_unix(midnight, unix_s), mic::Tt2000Status::kOk);
  EXPECT_EQ(unix_s, k2017);
  // Round trip over a day with millisecond times, both sides of 2012-07-01.
  for (double t = 1341100800.0 - 3600.0; t < 1341100800.0 + 3600.0; t += 0.125) {
    ASSERT_EQ(mic::tt2000_to_unix(mic::unix_to_tt2000(t), unix_s), mic::Tt2000Status::kOk);
    ASSERT_EQ(unix_s, t);
  }
}

TEST(CdfEpoch, FillBefore1972AndEpoch) {
  double unix_s = 0;
  EXPECT_EQ(mic::tt2000_to_unix(INT64_MIN, unix_s), mic::Tt2000Status::kFill);
  EXPECT_EQ(mic::tt2000_to_unix(INT64_MIN + 1, unix_s), mic::Tt2000Status::kFill);
  EXPECT_EQ(mic::tt2000_to_unix(-900000000 * kS, unix_s), mic::Tt2000Status::kBefore1972);
  EXPECT_EQ(mic::tt2000_to_unix(INT64_MAX, unix_s), mic::Tt2000Status::kTooLate);
  // CDF_EPOCH: 1970-01-01 is 62167219200000 ms after 0000-01-01.
  EXPECT_EQ(mic::cdf_epoch_to_unix(62167219200000.0), 0.0);
  EXPECT_EQ(mic::cdf_epoch_to_unix(62167219200000.0 + 1747180800000.0), 1747180800.0);
}
