// The cells behind a sandwich covariance (src/core/estimation/sandwich_cells.hpp): shares worked
// by hand for equal cells, one dominant cell, a cell of weight zero and a singular sum; on a
// simulated hour, one strong harmonic in the band leaves the sandwich fewer cells.
#include "../../../src/core/estimation/sandwich_cells.hpp"

#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/estimation/robust/robust_estimator.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "simulated_hour.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace mic = magnetometer_insitu_calibration;
using Cells = mic::detail::SandwichCells;

namespace {

/// A cell whose field DFT is `amplitude` along axis `axis`.
Cells::VectorXcd along(int axis, double amplitude) {
  Cells::VectorXcd x = Cells::VectorXcd::Zero(3);
  x(axis) = amplitude;
  return x;
}

double count_of(const std::vector<std::pair<Cells::VectorXcd, double>>& cells, const Eigen::Vector3d& sigma2) {
  Cells c(3);
  for (const auto& [x, w] : cells) c.add(x, w, sigma2);
  for (const auto& [x, w] : cells) c.share(x, w, sigma2);
  return c.count();
}

}  // namespace

TEST(SandwichCells, EqualCellsCountThemselvesAndADominantCellCountsForFewer) {
  // Twelve cells, four along each axis, of equal amplitude: each share is 3 / 4 (three columns,
  // one of four along its axis), so the count is the cells', 12, whatever the common weight and
  // residual powers.
  std::vector<std::pair<Cells::VectorXcd, double>> cells;
  for (int i = 0; i < 12; ++i) cells.emplace_back(along(i % 3, 1.0), 2.0);
  EXPECT_NEAR(count_of(cells, Eigen::Vector3d(1.0, 5.0, 0.1)), 12.0, 1e-12);
  // A cell of weight zero is not in the sandwich.
  cells.emplace_back(along(0, 7.0), 0.0);
  EXPECT_NEAR(count_of(cells, Eigen::Vector3d::Ones()), 12.0, 1e-12);
  cells.pop_back();
  // One of the x cells three times stronger: along x, sum 3 + 9 = 12, shares 3 x 1/12 (three
  // cells) and 3 x 9/12; along y and z 3/4 each (eight cells). Sum 9, sum of squares
  // 3 x 0.0625 + 5.0625 + 8 x 0.5625 = 9.75: 81 / 9.75 = 8.31 cells of 12.
  cells[0].first = along(0, 3.0);
  EXPECT_NEAR(count_of(cells, Eigen::Vector3d::Ones()), 81.0 / 9.75, 1e-12);
  // No cell along z: the z column's sum is singular, no count.
  std::vector<std::pair<Cells::VectorXcd, double>> flat;
  for (int i = 0; i < 8; ++i) flat.emplace_back(along(i % 2, 1.0), 1.0);
  EXPECT_TRUE(std::isnan(count_of(flat, Eigen::Vector3d::Ones())));
}

TEST(SandwichCells, OneStrongHarmonicLeavesTheSandwichFewerCells) {
  // A simulated hour (36 harmonics in 0.0002-0.01 Hz): the simulator's smooth spectrum spreads
  // the sandwich over most cells. The same hour with a 10 nT pulsation at harmonic 20 (5.6 mHz,
  // Pc5), in both instruments as the field is: that cell carries most of the sandwich, and both
  // estimators say so.
  const mic::SimulatedPair smooth = mic::test::simulated_hour(46);
  mic::SimulatedPair pulsating = smooth;
  const Eigen::Matrix3d n = pulsating.n_true;
  for (Eigen::Index i = 0; i < pulsating.reference.values_nT.rows(); ++i) {
    const Eigen::RowVector3d b = 10.0 * std::sin(2.0 * M_PI * 20.0 * static_cast<double>(i) / 3600.0) *
                                 Eigen::RowVector3d(1.0, 0.6, 0.3);
    pulsating.reference.values_nT.row(i) += b;
    pulsating.test.values_nT.row(i) += b * n;
  }
  for (const mic::EstimatorSettings& settings : {mic::EstimatorSettings{}, mic::test::plain_eq2_settings()}) {
    mic::WindowEstimator estimator(settings);
    const mic::WindowEstimate a = estimator.estimate(smooth.reference.values_nT, smooth.test.values_nT, 1.0);
    const mic::WindowEstimate b = estimator.estimate(pulsating.reference.values_nT, pulsating.test.values_nT, 1.0);
    ASSERT_EQ(a.quality, mic::Quality::kOk) << a.quality_text;
    ASSERT_EQ(b.quality, mic::Quality::kOk) << b.quality_text;
    EXPECT_LE(a.covariance_dof, 36.0 + 1e-9) << a.method;
    EXPECT_GT(a.covariance_dof, 18.0) << a.method;
    EXPECT_LT(b.covariance_dof, 0.5 * a.covariance_dof) << a.method;
    std::printf("%s: %.1f cells of 36; with the pulsation %.1f\n", a.method.c_str(), a.covariance_dof,
                b.covariance_dof);
  }
}
