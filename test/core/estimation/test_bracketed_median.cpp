// BracketedMedian (internal to the residual screen) against a median by full sort, for brackets
// that hold the middle, miss it on either side, are empty, NaN or zero-wide, on data with ties,
// drift and outliers: the value must be the same double in every case.
#include "../../../src/core/estimation/bracketed_median.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace {

using magnetometer_insitu_calibration::detail::BracketedMedian;
using magnetometer_insitu_calibration::detail::subsampled_median;

/// Middle value of a sorted copy, or for even n 0.5 (upper middle + lower middle).
double sorted_median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t mid = v.size() / 2;
  return v.size() % 2 == 1 ? v[mid] : 0.5 * (v[mid] + v[mid - 1]);
}

std::vector<double> sample(std::mt19937_64& rng, std::size_t n, int kind) {
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> x(n);
  for (std::size_t i = 0; i < n; ++i) {
    switch (kind) {
      case 0: x[i] = normal(rng); break;                                      // Gaussian, nT
      case 1: x[i] = std::round(normal(rng) * 2.0); break;                    // many ties
      case 2: x[i] = 0.01 * static_cast<double>(i) + normal(rng); break;      // drift
      case 3: x[i] = (i % 7 == 0) ? 1e6 * normal(rng) : normal(rng); break;   // outliers
      default: x[i] = 3.0; break;                                             // constant
    }
  }
  return x;
}

TEST(BracketedMedian, EqualsTheSortedMedianForAnyBracket) {
  std::mt19937_64 rng(17);
  BracketedMedian selector;
  int cases = 0, bracketed = 0;
  for (std::size_t n : {1u, 2u, 3u, 4u, 5u, 10u, 11u, 100u, 101u, 3600u, 3601u}) {
    for (int kind = 0; kind < 5; ++kind) {
      const std::vector<double> x = sample(rng, n, kind);
      const double expected = sorted_median(x);
      // centre, half width: right, narrow, off to either side, huge, zero, NaN.
      const double guesses[][2] = {{expected, 0.5}, {expected, 1e-9}, {expected + 5.0, 0.1}, {expected - 5.0, 0.1},
                                   {expected, 1e9}, {expected, 0.0}, {std::nan(""), 1.0}, {-1e12, 1e-3}};
      for (const auto& g : guesses) {
        const double got = selector.median(x.data(), n, g[0], g[1]);
        EXPECT_EQ(got, expected) << "n " << n << " kind " << kind << " centre " << g[0] << " half width " << g[1];
        bracketed += selector.last_inside() < n;
        ++cases;
      }
      EXPECT_EQ(subsampled_median(x.data(), n, selector), expected) << "n " << n << " kind " << kind;
    }
  }
  // The bracket path itself was taken, not only the full selection (most guesses above are
  // deliberately wrong; 84 of 440 cases are proven inside their bracket).
  EXPECT_GT(bracketed, cases / 8);
}

}  // namespace
