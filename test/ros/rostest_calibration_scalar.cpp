// rostest_calibration, scalar.test (Calibration.ScalarTopic): a scalar magnetometer on
// ~scalar_topic. The reference reads 0.3 % high along every axis; F (simulation/
// scalar_magnetometer.hpp) every second, 0.37 s off the pair's stamps. Every published
// calibration carries the scalar check, and its reference scale along the field holds the truth
// within its interval.
#include "calibration_harness.hpp"
#include "magnetometer_insitu_calibration/simulation/scalar_magnetometer.hpp"

using namespace calibration_rostest;

namespace {

constexpr double kReferenceScale = 1.003;  // the reference's scale error along every axis
// 3 h 20 min of pairs: windows of 3 h every 10 min -> windows starting at t0 and t0 + 600 s.
constexpr std::size_t kPairedSamples = 12000;

}  // namespace

TEST(Calibration, ScalarTopic) {
  mic::SimulationSettings sim = simulation(static_cast<double>(kPairedSamples), 41);
  Harness h(sim);
  mic::ScalarMagnetometerSettings sm;
  sm.seed = 43;
  h.add_scalar(param("scalar_topic", "/sim/scalar"), mic::simulate_scalar_magnetometer(h.pair(), sm));
  h.scale_reference(kReferenceScale);
  ASSERT_TRUE(h.wait_for_connections(1, 2)) << "nodes did not connect";
  ASSERT_TRUE(h.wait([&] { return h.scalar_subscribers() >= 1; }, 30.0)) << "calibration_node did not subscribe to F";
  h.publish(0, kPairedSamples, true, true);
  ASSERT_TRUE(h.wait([&] { return h.calibrations().size() >= 2; }, 60.0)) << "timed out waiting for the calibrations";
  std::lock_guard<std::mutex> lock(h.mutex());
  for (const mic::MagnetometerCalibration& c : h.calibrations()) {
    SCOPED_TRACE(c.scalar_text);
    EXPECT_NE(c.scalar_text.find("reference scale along the field"), std::string::npos);
    ASSERT_TRUE(std::isfinite(c.reference_scale_along_field));
    // A 3 h window finds the scale to a few tenths of a percent: an interval that says something.
    EXPECT_GT(c.reference_scale_along_field_ci95, 0.0);
    EXPECT_LT(c.reference_scale_along_field_ci95, 0.01);
    EXPECT_NEAR(c.reference_scale_along_field, kReferenceScale, c.reference_scale_along_field_ci95);
    EXPECT_EQ(c.reference_needs_calibration,
              std::abs(c.reference_scale_along_field - 1.0) > c.reference_scale_along_field_ci95);
    // The field's direction: a unit vector.
    const Eigen::Vector3d u(c.direction_cosines[0], c.direction_cosines[1], c.direction_cosines[2]);
    EXPECT_NEAR(u.norm(), 1.0, 1e-9);
  }
}
