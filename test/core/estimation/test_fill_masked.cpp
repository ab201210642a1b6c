// The robust screen's fill of masked runs (src/core/estimation/spectral_tools.hpp, fill_masked):
// the line between the means of the unmasked samples on either side, over as many samples as the
// run is long, in both records; checked against values worked by hand, a linear signal, the
// record's ends, and the noise it puts into a masked run.
#include "../../../src/core/estimation/spectral_tools.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

TEST(FillMasked, LineBetweenLocalMeansWorkedByHand) {
  // x = 0 1 2 [3 4] 5 6 7 with samples 3, 4 masked (run of 2): left mean of samples 1, 2 at epoch
  // 1.5, right mean of samples 5, 6 at epoch 5.5. Values 10 0 2 [x x] 8 4 9:
  // left (0 + 2) / 2 = 1, right (8 + 4) / 2 = 6, slope 5 / 4: sample 3 -> 1 + 1.5 * 1.25 = 2.875,
  // sample 4 -> 1 + 2.5 * 1.25 = 4.125.
  mic::Readings r(8, 3), t(8, 3);
  const double v[8] = {10, 0, 2, 99, 99, 8, 4, 9};
  for (int i = 0; i < 8; ++i) {
    r.row(i).setConstant(v[i]);
    t.row(i).setConstant(2.0 * v[i]);
  }
  const std::vector<char> mask = {0, 0, 0, 1, 1, 0, 0, 0};
  mic::detail::fill_masked(r, t, mask);
  EXPECT_DOUBLE_EQ(r(3, 0), 2.875);
  EXPECT_DOUBLE_EQ(r(4, 2), 4.125);
  EXPECT_DOUBLE_EQ(t(3, 1), 5.75);  // the same weights in the test record
  EXPECT_DOUBLE_EQ(r(0, 0), 10.0);  // unmasked samples untouched
  EXPECT_DOUBLE_EQ(r(5, 0), 8.0);
}

TEST(FillMasked, ReproducesALinearSignalAndHoldsTheEndsFlat) {
  mic::Readings r(40, 3), t(40, 3);
  for (int i = 0; i < 40; ++i) {
    r.row(i) << 3.0 * i, -2.0 * i + 5.0, 0.5 * i;
    t.row(i) = 2.0 * r.row(i);
  }
  std::vector<char> mask(40, 0);
  for (int i = 10; i < 17; ++i) mask[static_cast<std::size_t>(i)] = 1;  // inside: exact line
  for (int i = 0; i < 3; ++i) mask[static_cast<std::size_t>(i)] = 1;    // at the start: flat
  mic::detail::fill_masked(r, t, mask);
  for (int i = 10; i < 17; ++i) {
    EXPECT_NEAR(r(i, 0), 3.0 * i, 1e-12) << i;
    EXPECT_NEAR(r(i, 1), -2.0 * i + 5.0, 1e-12) << i;
    EXPECT_NEAR(t(i, 2), 1.0 * i, 1e-12) << i;
  }
  // Start: the mean of the 3 samples after the run (3, 4, 5), held flat.
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(r(i, 0), 12.0, 1e-12) << i;
}

TEST(FillMasked, PutsLessNoiseIntoTheRunThanALineThroughTwoSamples) {
  // White noise of unit variance, runs of 61 samples: a line through the two neighbours has a
  // mean square of 2/3 ... 1 over the run (its ends carry the full noise); through means over 61
  // samples, about 1/61 of that. Measured over 200 runs.
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal;
  const int runs = 200, length = 61, period = 3 * length;
  mic::Readings r(runs * period, 3), t(runs * period, 3);
  for (Eigen::Index i = 0; i < r.rows(); ++i)
    for (int c = 0; c < 3; ++c) r(i, c) = normal(rng), t(i, c) = 0.0;
  std::vector<char> mask(static_cast<std::size_t>(r.rows()), 0);
  for (int k = 0; k < runs; ++k)
    for (int i = 0; i < length; ++i) mask[static_cast<std::size_t>(k * period + length + i)] = 1;
  mic::detail::fill_masked(r, t, mask);
  double sum2 = 0.0;
  for (int k = 0; k < runs; ++k)
    for (int i = 0; i < length; ++i) sum2 += r(k * period + length + i, 0) * r(k * period + length + i, 0);
  const double mean_square = sum2 / (runs * length);
  EXPECT_LT(mean_square, 0.05);  // two single neighbours: about 0.67
  EXPECT_GT(mean_square, 0.002);
}
