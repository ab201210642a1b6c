// ROS layer without a master, temperature terms: the correction model's inverse of the
// temperature model against numbers worked by hand.
#include "magnetometer_insitu_calibration/ros/correction_model.hpp"

#include <Eigen/LU>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <utility>

namespace mic = magnetometer_insitu_calibration;

namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace

TEST(CorrectionModel, TemperatureTermsInvertTheModelWithHandWorkedNumbers) {
  // n = I, d = 0; c = (0.2, -0.15, 0.3) nT/degC, s = (15, -10, 25) ppm/degC, theta_ref 20 degC,
  // theta 22 degC (u = 2). Field r = (20000, 1000, 45000) nT reads, by the model
  // t_l = r_l (1 + s_l u) + c_l u:
  //   t_x = 20000 * 1.00003 + 0.4 = 20001.0, t_y = 1000 * 0.99998 - 0.3 = 999.68,
  //   t_z = 45000 * 1.00005 + 0.6 = 45002.85.
  mic::CorrectionModel model(Eigen::Matrix3d::Identity(), mic::Matrix9d::Zero(), 100.0);
  EXPECT_FALSE(model.has_temperature());
  const Eigen::Vector3d t(20001.0, 999.68, 45002.85);
  EXPECT_EQ(model.correct(t, 22.0), model.correct(t));  // no terms: plain correction
  model.set_temperature(20.0, Eigen::Vector3d(0.2, -0.15, 0.3), Eigen::Vector3d(15e-6, -10e-6, 25e-6));
  EXPECT_TRUE(model.has_temperature());
  const Eigen::Vector3d r = model.correct(t, 22.0);
  EXPECT_NEAR(r(0), 20000.0, 1e-9);
  EXPECT_NEAR(r(1), 1000.0, 1e-9);
  EXPECT_NEAR(r(2), 45000.0, 1e-9);
  EXPECT_EQ(model.correct(t, 20.0), model.correct(t));  // at the reference temperature: no change
  EXPECT_THROW(model.set_temperature(kNaN, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()), std::invalid_argument);

  // A general n and offset d: t = n^T r (1 + s u) + c u + d worked here, inverted by the model.
  Eigen::Matrix3d n;
  n << 1.0002, 0.0011, -0.0007, -0.0013, 0.9991, 0.0021, 0.0005, -0.0017, 1.0004;
  const Eigen::Vector3d d(12.5, -3.0, 40.0), c(0.2, -0.15, 0.3), s(15e-6, -10e-6, 25e-6), field(21000.0, -450.0, 43500.0);
  mic::CorrectionModel general(n, mic::Matrix9d::Zero(), 100.0, d);
  general.set_temperature(19.0, c, s);
  const double u = 25.5 - 19.0;
  const Eigen::Vector3d reading = (n.transpose() * field).cwiseProduct((Eigen::Vector3d::Ones() + u * s)) + u * c + d;
  EXPECT_LT((general.correct(reading, 25.5) - field).norm(), 1e-8);
  // Without the terms the same reading is off by about (c + s F) u: nT.
  EXPECT_GT((general.correct(reading) - field).norm(), 1.0);
}

TEST(CorrectionModel, TemperatureTermsUncertaintyWithHandWorkedNumbers) {
  // n = I, d = (10, 0, 0) nT, no n covariance, a zero test covariance: what is left is the terms'.
  // theta_ref 20 degC, theta 23 degC (u = 3); s = (20, 0, -10) ppm/degC; standard errors of a
  // (0.02, 0.01, 0.05) nT/degC and of s (4, 0, 2) ppm/degC; window mean test field
  // F = (20010, 1000, 45000) nT. For the reading corrected to r = (20500, 1000, 44000) nT:
  // y = n^T r = r, the lever y + d - F = (500, 0, -1000) nT, and
  //   var_l = (u / (1 + s_l u))^2 (se_a^2 + lever^2 se_s^2):
  //   x: (3 / 1.00006)^2 (0.0004 + 500^2 * 16e-12) = 8.99892 * 0.000404 = 0.0036356,
  //   y: 9 * 0.0001 = 0.0009,
  //   z: (3 / 0.99997)^2 (0.0025 + 1e6 * 4e-12) = 9.00054 * 0.002504 = 0.0225374 (nT^2).
  mic::CorrectionModel model(Eigen::Matrix3d::Identity(), mic::Matrix9d::Zero(), 100.0, Eigen::Vector3d(10.0, 0.0, 0.0));
  model.set_temperature(20.0, Eigen::Vector3d(0.1, 0.1, 0.1), Eigen::Vector3d(20e-6, 0.0, -10e-6));
  const Eigen::Vector3d r(20500.0, 1000.0, 44000.0);
  const Eigen::Matrix3d zero = Eigen::Matrix3d::Zero();
  EXPECT_EQ(model.corrected_covariance(zero, r, true, 23.0).norm(), 0.0) << "no uncertainty given yet";
  model.set_temperature_uncertainty(Eigen::Vector3d(0.02, 0.01, 0.05), Eigen::Vector3d(4e-6, 0.0, 2e-6),
                                    Eigen::Vector3d(20010.0, 1000.0, 45000.0));
  const Eigen::Matrix3d c = model.corrected_covariance(zero, r, true, 23.0);
  EXPECT_NEAR(c(0, 0), 0.0036356, 1e-7);
  EXPECT_NEAR(c(1, 1), 0.0009, 1e-9);
  EXPECT_NEAR(c(2, 2), 0.0225374, 1e-7);
  EXPECT_EQ(c(0, 1), 0.0);
  // At the reference temperature, without a temperature, or without the calibration's own
  // uncertainty asked for: nothing added.
  EXPECT_EQ(model.corrected_covariance(zero, r, true, 20.0).norm(), 0.0);
  EXPECT_EQ(model.corrected_covariance(zero, r, true).norm(), 0.0);
  EXPECT_EQ(model.corrected_covariance(zero, r, false, 23.0).norm(), 0.0);
  EXPECT_THROW(model.set_temperature_uncertainty(Eigen::Vector3d(-1.0, 0.0, 0.0), Eigen::Vector3d::Zero(),
                                                 Eigen::Vector3d::Zero()),
               std::invalid_argument);
}
