// rostest_calibration, scalar.test (Calibration.ScalarTopic): a scalar magnetometer on
// ~scalar_topic. The reference reads 0.3 % high along every axis; F (simulation/
// scalar_magnetometer.hpp) every second, 0.37 s off the pair's stamps. Every published
// calibration carries the scalar check, and its reference scale along the field holds the truth
// (at a bound exceeded by chance with probability below 1e-6). With the main field's D and I (~field_direction), the diagnostics give
// the reference's scale along x and z (y is across the field), each holding 1.003.
#include "calibration_harness.hpp"
#include "magnetometer_insitu_calibration/estimation/scalar_check.hpp"
#include "magnetometer_insitu_calibration/simulation/scalar_magnetometer.hpp"

using namespace calibration_rostest;

namespace {

constexpr double kReferenceScale = 1.003;  // the reference's scale error along every axis
// 3 h 20 min of pairs: windows of 3 h every 10 min -> windows starting at t0 and t0 + 600 s.
constexpr std::size_t kScalarSamples = 12000;
// The truth is checked only at bounds exceeded by chance with probability below 1e-6: 3.2 of the
// check's 95 % half-widths for up to three parameters at once (Bonferroni), from the 30 or more
// spectral cells of a 3-hour window (Student's t: 6.5 / 2.04 standard errors at 30 dof).
constexpr double kScalarTruthBound = 3.2;

}  // namespace

TEST(Calibration, ScalarTopic) {
  mic::SimulationSettings sim = simulation(static_cast<double>(kScalarSamples), 41);
  Harness h(sim);
  mic::ScalarMagnetometerSettings sm;
  sm.seed = 43;
  h.add_scalar(param("scalar_topic", "/sim/scalar"), mic::simulate_scalar_magnetometer(h.pair(), sm));
  h.scale_reference(kReferenceScale);
  ASSERT_TRUE(h.wait_for_connections(1, 2)) << "nodes did not connect";
  ASSERT_TRUE(h.wait([&] { return h.scalar_subscribers() >= 1; }, kPatience_s)) << "calibration_node did not subscribe to F";
  // The direction the node was given is the simulated main field's.
  const mic::FieldDirection given = mic::parse_field_direction(param("field_direction"));
  EXPECT_LT(std::acos(std::min(1.0, given.unit().dot(sim.main_field_nT.normalized()))) * 180.0 / M_PI, 1e-3);
  h.publish(0, kScalarSamples, true, true);
  ASSERT_TRUE(h.wait([&] { return h.calibrations().size() >= 2; }, kPatience_s)) << "timed out waiting for the calibrations";
  const bool diagnosed = h.wait_ticking([&] {
    const DiagnosticRecord* d = h.latest_diagnostic("calibration_sim: sim");
    return d != nullptr && d->values.count("scalar check (last window)") != 0;
  }, kPatience_s);
  std::lock_guard<std::mutex> lock(h.mutex());
  ASSERT_TRUE(diagnosed) << "no scalar check in the diagnostics";
  const DiagnosticRecord* d = h.latest_diagnostic("calibration_sim: sim");
  EXPECT_NE(d->values.at("scalar check (last window)").find("reference scale x"), std::string::npos);
  for (const char* axis : {"x", "z"}) {
    const double scale = std::stod(d->values.at(std::string("reference scale ") + axis + " (given direction)"));
    const double ci95 = std::stod(d->values.at(std::string("reference scale ") + axis + " ci95 (given direction)"));
    EXPECT_GT(ci95, 0.0) << axis;
    EXPECT_NEAR(scale, kReferenceScale, kScalarTruthBound * ci95) << axis;
  }
  EXPECT_EQ(d->values.at("reference scale y (given direction)"), "nan");  // |b_y| = 0.02: not determined
  // The fitted direction's angle from the given one, a 2-D offset: beyond 5.3 standard errors with
  // probability exp(-5.3^2 / 2) = 1e-6 (Rayleigh), kScalarTruthBound half-widths from 30 cells.
  const double offset = std::stod(d->values.at("fitted direction from the given (deg)"));
  EXPECT_LT(offset, kScalarTruthBound * std::stod(d->values.at("fitted direction from the given ci95 (deg)")));
  // The WARN that the reference needs calibration when, and only when, the last window's scale
  // along the field excludes 1 (1.003 from 3-hour windows: +- 0.1-0.3 %).
  const mic::MagnetometerCalibration& last = h.calibrations().back();  // of the two windows, the last
  EXPECT_EQ(d->message.find("the reference needs calibration") != std::string::npos, last.reference_needs_calibration)
      << d->message << "; " << last.scalar_text;
  if (last.reference_needs_calibration) {
    EXPECT_EQ(d->level, 1) << d->message;
  }
  for (const mic::MagnetometerCalibration& c : h.calibrations()) {
    SCOPED_TRACE(c.scalar_text);
    EXPECT_NE(c.scalar_text.find("reference scale along the field"), std::string::npos);
    ASSERT_TRUE(std::isfinite(c.reference_scale_along_field));
    // A 3 h window finds the scale to a few tenths of a percent: an interval that says something.
    EXPECT_GT(c.reference_scale_along_field_ci95, 0.0);
    EXPECT_LT(c.reference_scale_along_field_ci95, 0.01);
    EXPECT_NEAR(c.reference_scale_along_field, kReferenceScale, kScalarTruthBound * c.reference_scale_along_field_ci95);
    EXPECT_EQ(c.reference_needs_calibration,
              std::abs(c.reference_scale_along_field - 1.0) > c.reference_scale_along_field_ci95);
    // The field's direction: a unit vector.
    const Eigen::Vector3d u(c.direction_cosines[0], c.direction_cosines[1], c.direction_cosines[2]);
    EXPECT_NEAR(u.norm(), 1.0, 1e-9);
  }
}
