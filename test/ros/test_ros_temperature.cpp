// ROS layer without a master, temperature terms (issue 14): the thermometer buffer and its grid,
// the live window estimate with a simulated hut temperature, and the correction model's inverse
// of the temperature model against numbers worked by hand.
#include "magnetometer_insitu_calibration/ros/correction_model.hpp"
#include "magnetometer_insitu_calibration/ros/live_window.hpp"
#include "magnetometer_insitu_calibration/simulation/hut_temperature.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include "../core/hut_fixture.hpp"

#include <Eigen/LU>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <utility>

namespace mic = magnetometer_insitu_calibration;

namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();

struct HutWindow {
  mic::SimulatedPair pair;
  mic::HutTemperatureSettings hut;
  mic::WindowData window;
};

/// A 6 h simulated window at 1 Hz with the hut's temperature effect on the test, and the
/// thermometer channel as the window's temperature samples.
HutWindow hut_window(std::uint64_t seed) {
  HutWindow h;
  mic::test::HutPair hut = mic::test::hut_pair(seed, 21600.0);
  h.pair = std::move(hut.pair);
  h.hut = hut.hut;
  mic::WindowData& w = h.window;
  w.start_s = h.pair.reference.time_s.front();
  w.period_s = 1.0;
  w.expected_samples = h.pair.reference.size();
  w.paired.time_s = h.pair.reference.time_s;
  w.paired.reference_nT = h.pair.reference.values_nT;
  w.paired.test_nT = h.pair.test.values_nT;
  w.temperature.subscribed = true;
  w.temperature.time_s = h.pair.test.time_s;
  w.temperature.value_C = h.pair.test.auxiliary.at(0).values;
  return h;
}

}  // namespace

TEST(TemperatureBuffer, KeepsOrderedSamplesWithinItsSpanAndCopiesAWindow) {
  mic::TemperatureBuffer buffer(100.0);  // s
  for (int k = 0; k < 50; ++k) buffer.push(1000.0 + k, 20.0 + 0.1 * k);
  buffer.push(1020.0, 99.0);  // not later than the newest: ignored
  EXPECT_EQ(buffer.out_of_order(), 1u);
  EXPECT_EQ(buffer.buffered(), 50u);
  const mic::TemperatureSamples s = buffer.copy(1010.0, 1012.0);
  EXPECT_TRUE(s.subscribed);
  ASSERT_EQ(s.time_s.size(), 3u);
  EXPECT_EQ(s.time_s.front(), 1010.0);
  EXPECT_DOUBLE_EQ(s.value_C.back(), 21.2);
  buffer.drop_before(1040.0);
  EXPECT_EQ(buffer.buffered(), 10u);
  buffer.push(1200.0, 25.0);  // 160 s after the oldest kept: everything older than 1100 s goes
  EXPECT_EQ(buffer.buffered(), 1u);
  buffer.reset();
  EXPECT_EQ(buffer.buffered(), 0u);
}

TEST(TemperatureOnGrid, InterpolatesAndHoldsTheEdgesOnlyWithinTheGap) {
  mic::TemperatureSamples s;
  s.subscribed = true;
  s.time_s = {10.0, 13.0, 100.0};
  s.value_C = {20.0, 21.5, 30.0};
  const std::vector<double> at = {5.0, 7.0, 11.5, 60.0, 103.0, 106.0};
  const Eigen::VectorXd g = mic::temperature_on_grid(s, at, 4.0);
  EXPECT_TRUE(std::isnan(g(0)));   // 5 s before the first sample: more than 4 s
  EXPECT_EQ(g(1), 20.0);           // 3 s before: held
  EXPECT_DOUBLE_EQ(g(2), 20.75);   // linear
  EXPECT_TRUE(std::isnan(g(3)));   // inside an 87 s gap
  EXPECT_EQ(g(4), 30.0);           // 3 s after the last: held
  EXPECT_TRUE(std::isnan(g(5)));
  mic::TemperatureSamples none;
  none.subscribed = true;
  EXPECT_TRUE(mic::temperature_on_grid(none, at, 4.0).array().isNaN().all());
}

TEST(EstimateWindow, HutTemperatureGivesTheApparentCoefficientsWithinTheirIntervals) {
  HutWindow h = hut_window(31);
  mic::EstimatorSettings settings;
  mic::WindowEstimator estimator(settings);
  mic::WindowGapRule rule;
  const mic::WindowResult r = mic::estimate_window(h.window, estimator, rule);
  ASSERT_TRUE(r.temperature.fitted) << r.temperature.text;
  EXPECT_TRUE(r.temperature_known);
  EXPECT_EQ(r.temperature_samples, h.pair.reference.size());
  EXPECT_EQ(r.estimate.quality, mic::Quality::kOk) << r.estimate.quality_text;
  const Eigen::VectorXd theta = Eigen::Map<const Eigen::VectorXd>(h.pair.test.auxiliary[0].values.data(),
                                                                  static_cast<Eigen::Index>(h.pair.reference.size()));
  EXPECT_NEAR(r.temperature.reference_C, theta.mean(), 1e-9);
  for (int l = 0; l < 3; ++l) {
    // a = c + s F, F the window's mean field in the test frame.
    const double truth = h.hut.offset_nT_per_C(l) + 1e-6 * h.hut.scale_ppm_per_C(l) * h.pair.test.values_nT.col(l).mean();
    EXPECT_LT(std::abs(r.temperature.apparent_nT_per_C(l) - truth), r.temperature.apparent_ci95_nT_per_C(l))
        << "component " << l << ": " << r.temperature.apparent_nT_per_C(l) << " +- "
        << r.temperature.apparent_ci95_nT_per_C(l) << " vs " << truth;
  }
  // The same window without a temperature topic: estimated as before, the text says why.
  h.window.temperature = mic::TemperatureSamples{};
  const mic::WindowResult without = mic::estimate_window(h.window, estimator, rule);
  EXPECT_FALSE(without.temperature.fitted);
  EXPECT_EQ(without.temperature.text, "no temperature topic: estimated without temperature terms");
  for (int l = 0; l < 3; ++l) EXPECT_LT(r.estimate.residual_rms_nT(l), without.estimate.residual_rms_nT(l)) << l;
}

TEST(EstimateWindow, MissingOrConstantTemperatureIsEstimatedWithoutTheTerms) {
  HutWindow h = hut_window(32);
  mic::EstimatorSettings settings;
  mic::WindowEstimator estimator(settings);
  mic::WindowGapRule rule;
  mic::WindowData constant = h.window;
  for (double& v : constant.temperature.value_C) v = 21.5;
  const mic::WindowResult c = mic::estimate_window(constant, estimator, rule);
  EXPECT_FALSE(c.temperature.fitted);
  EXPECT_NE(c.temperature.text.find("temperature range 0 degC below 0.05 degC"), std::string::npos) << c.temperature.text;
  EXPECT_EQ(c.temperature.reference_C, 21.5);
  mic::WindowData empty = h.window;
  empty.temperature.time_s.clear();
  empty.temperature.value_C.clear();
  const mic::WindowResult e = mic::estimate_window(empty, estimator, rule);
  EXPECT_FALSE(e.temperature.fitted);
  EXPECT_EQ(e.temperature.text, "no temperature sample in the window: estimated without temperature terms");
  mic::WindowData gap = h.window;  // a 10 min hole in the thermometer (max gap 60 s)
  gap.temperature.time_s.erase(gap.temperature.time_s.begin() + 5000, gap.temperature.time_s.begin() + 5600);
  gap.temperature.value_C.erase(gap.temperature.value_C.begin() + 5000, gap.temperature.value_C.begin() + 5600);
  const mic::WindowResult g = mic::estimate_window(gap, estimator, rule);
  EXPECT_FALSE(g.temperature.fitted);
  EXPECT_FALSE(g.temperature_known);
  EXPECT_NE(g.temperature.text.find("NaN"), std::string::npos) << g.temperature.text;
  // All three: the estimate of the window without temperature terms.
  mic::WindowData plain = h.window;
  plain.temperature = mic::TemperatureSamples{};
  const mic::WindowResult p = mic::estimate_window(plain, estimator, rule);
  EXPECT_EQ(c.estimate.n, p.estimate.n);
  EXPECT_EQ(e.estimate.n, p.estimate.n);
  EXPECT_EQ(g.estimate.n, p.estimate.n);
}

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
