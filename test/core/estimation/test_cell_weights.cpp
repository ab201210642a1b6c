// The robust estimator's cell weights (cell_weights.hpp) against their formulas worked by hand.
#include "magnetometer_insitu_calibration/estimation/robust/cell_weights.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace mic = magnetometer_insitu_calibration;

TEST(CellWeights, HuberIsOneUpToKThenKOverD) {
  const mic::HuberWeights huber(2.0);  // sigmas
  EXPECT_EQ(huber.weight(0.0), 1.0);
  EXPECT_EQ(huber.weight(2.0), 1.0);
  EXPECT_EQ(huber.weight(4.0), 0.5);
  EXPECT_EQ(huber.weight(8.0), 0.25);
  EXPECT_TRUE(std::isnan(huber.weight(std::numeric_limits<double>::quiet_NaN())));
}

TEST(CellWeights, UnitWeightsAreOne) {
  const mic::UnitWeights unit;
  EXPECT_EQ(unit.weight(0.0), 1.0);
  EXPECT_EQ(unit.weight(100.0), 1.0);
}

TEST(CellWeights, RejectingCutsBeyondTheLimitOnly) {
  const mic::HuberWeights huber(2.0);
  const mic::RejectingWeights rejecting(huber, 5.0);  // sigmas
  EXPECT_EQ(rejecting.weight(1.0), 1.0);
  EXPECT_EQ(rejecting.weight(4.0), 0.5);
  EXPECT_EQ(rejecting.weight(5.0), 0.4);  // at the limit: kept
  EXPECT_EQ(rejecting.weight(5.0001), 0.0);
  EXPECT_TRUE(std::isnan(rejecting.weight(std::numeric_limits<double>::quiet_NaN())));  // NaN is not beyond
  const mic::UnitWeights unit;
  EXPECT_EQ(mic::RejectingWeights(unit, 5.0).weight(6.0), 0.0);
}
