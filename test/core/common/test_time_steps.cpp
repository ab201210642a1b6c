// common/time_steps.hpp: the median step of a record's stamps.
#include "magnetometer_insitu_calibration/common/time_steps.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace mic = magnetometer_insitu_calibration;

TEST(MedianTimeStep, IsTheNominalPeriodThroughGapsAndOddStamps) {
  // 1 s stamps with a 10 s gap and one stamp 0.37 s late: the period is still 1 s.
  EXPECT_DOUBLE_EQ(mic::median_time_step({0.0, 1.0, 2.0, 12.0, 13.0, 14.37, 15.0, 16.0}), 1.0);
  // A GP20S3 every 30 s, 0.37 s off the minutes.
  EXPECT_DOUBLE_EQ(mic::median_time_step({0.37, 30.37, 60.37, 90.37}), 30.0);
  // An even number of steps: the upper of the two middle ones (steps 1, 2, 3, 4 -> 3).
  EXPECT_DOUBLE_EQ(mic::median_time_step({0.0, 1.0, 3.0, 6.0, 10.0}), 3.0);
}

TEST(MedianTimeStep, ZeroWithFewerThanTwoStamps) {
  EXPECT_EQ(mic::median_time_step({}), 0.0);
  EXPECT_EQ(mic::median_time_step({5.0}), 0.0);
}
