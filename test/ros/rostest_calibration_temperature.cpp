// rostest_calibration, temperature.test (Calibration.TemperatureTerms): a simulated hut pair
// (hut_temperature.hpp: known offset and scale coefficients) with the test's thermometer on its
// sensor_msgs/Temperature topic. calibration_node (~temperature_topic) publishes a calibration
// with temperature_fitted and the apparent coefficients within their 95 % intervals of the
// truth a_l = c_l + s_l mean(T_l); correction_node with the temperature topic (apparent and
// full ~temperature_model) corrects the following hours closer to the clean field than a
// correction_node without it.
#include "calibration_harness.hpp"
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"

#include <cstdio>

using namespace calibration_rostest;

TEST(Calibration, TemperatureTerms) {
  // 6 h at 1 Hz; one window of 4 h (00:00-04:00 UTC, the night's cool side of the daily cycle
  // plus the heater's 30 min cycles); samples of 04:00-06:00 are corrected with it while the
  // hut warms by about a degC.
  const double window_s = 14400.0;
  const std::string temperature_topic = param("temperature_topic", "/sim/test/temperature");
  Harness h(simulation(21600.0, 41));
  mic::HutTemperatureSettings hut;
  hut.seed = 41;
  h.add_hut_temperature(hut, temperature_topic);
  const std::string with = param("corrected_topic", "/sim/corrected");
  const std::string without = param("corrected_plain_topic", "/sim/corrected_plain");
  h.subscribe_corrected(with);
  h.subscribe_corrected(without);
  const std::string with_full = param("corrected_full_topic", "/sim/corrected_full");
  h.subscribe_corrected(with_full);
  const std::string file = param("calibration_file");
  ASSERT_FALSE(file.empty());
  std::remove(file.c_str());
  ASSERT_TRUE(h.wait_for_connections(1, 4)) << "nodes did not connect";
  ASSERT_TRUE(h.wait([&] { return h.temperature_subscribers() >= 3; }, kPatience_s)) << "temperature not subscribed";

  // The window's samples and a minute more (the despiker's delay), then, once the calibration
  // is out, the rest: the two hours after the window are corrected with it however long the
  // estimate took on this machine.
  const std::size_t n = h.pair().reference.size();
  const std::size_t window_done = static_cast<std::size_t>(window_s) + 60;
  h.publish(0, window_done, true, true);
  ASSERT_TRUE(h.wait([&] { return !h.calibrations().empty(); }, kPatience_s)) << "no calibration of the window";
  h.publish(window_done, n, true, true);
  const double last_stamp = h.pair().reference.time_s.back();
  ASSERT_TRUE(h.wait([&] {
    for (const std::string& topic : {with, without, with_full}) {
      const auto& c = h.corrected(topic);
      if (c.empty() || c.back().stamp_s < last_stamp) return false;
    }
    return !h.calibrations().empty();
  }, kPatience_s)) << "no calibration, or the corrected streams did not reach the last sample";
  ASSERT_TRUE(h.wait_fresh_diagnostics({"calibration_sim: sim", "correction_sim", "correction_plain", "correction_full"}, 30.0));

  std::lock_guard<std::mutex> lock(h.mutex());
  ASSERT_EQ(h.calibrations().size(), 1u);
  const mic::MagnetometerCalibration& c = h.calibrations().front();
  ASSERT_TRUE(c.accepted) << c.quality_text;
  ASSERT_TRUE(c.temperature_fitted) << c.temperature_text;
  EXPECT_NE(c.temperature_text.find("n at"), std::string::npos) << c.temperature_text;
  // Truth of the window: a = c + s F, F = mean(T_l) over the window's samples.
  const std::size_t count = static_cast<std::size_t>(window_s);
  const Eigen::Vector3d mean_test = h.pair().test.values_nT.topRows(static_cast<Eigen::Index>(count)).colwise().mean();
  const std::vector<double>& theta = h.pair().test.auxiliary.back().values;
  double mean_theta = 0.0;
  for (std::size_t i = 0; i < count; ++i) mean_theta += theta[i] / static_cast<double>(count);
  EXPECT_NEAR(c.temperature_reference_C, mean_theta, 0.01);
  EXPECT_GT(c.temperature_range_C, 0.5);
  for (int l = 0; l < 3; ++l) {
    const double truth = hut.offset_nT_per_C(l) + 1e-6 * hut.scale_ppm_per_C(l) * mean_test(l);
    std::printf("[ temperature ] component %d: apparent %.4f +- %.4f nT/degC, truth %.4f; scale %.1f +- %.1f ppm/degC "
                "(truth %.1f); offset %.2f +- %.2f nT/degC (truth %.2f)\n",
                l, c.temperature_apparent_nT_per_C[l], c.temperature_apparent_ci95_nT_per_C[l], truth,
                c.temperature_scale_ppm_per_C[l], c.temperature_scale_ci95_ppm_per_C[l], hut.scale_ppm_per_C(l),
                c.temperature_offset_nT_per_C[l], c.temperature_offset_ci95_nT_per_C[l], hut.offset_nT_per_C(l));
    // The three exceed this bound together with probability below 1e-6 (truth_bound).
    EXPECT_LT(std::abs(c.temperature_apparent_nT_per_C[l] - truth), truth_bound(c, 3) * c.temperature_apparent_ci95_nT_per_C[l])
        << "component " << l;
  }
  // The YAML file carries the terms.
  const mic::MagnetometerCalibration file_calibration = mic::load_calibration_file(file);
  std::string difference;
  EXPECT_TRUE(mic::calibrations_equal(file_calibration, c, &difference)) << difference;

  // Corrected with and without the temperature terms against the clean field (reference frame),
  // over the stamps both published (after the calibration was adopted).
  std::map<double, Eigen::Vector3d> plain;
  for (const CorrectedSample& s : h.corrected(without)) plain[s.stamp_s] = s.field_nT;
  const double start = h.start_s();
  std::map<double, Eigen::Vector3d> full;
  for (const CorrectedSample& s : h.corrected(with_full)) full[s.stamp_s] = s.field_nT;
  Eigen::Vector3d sum_with = Eigen::Vector3d::Zero(), sum_without = Eigen::Vector3d::Zero();
  Eigen::Vector3d sum_full = Eigen::Vector3d::Zero();
  std::size_t compared = 0;
  for (const CorrectedSample& s : h.corrected(with)) {
    const auto other = plain.find(s.stamp_s);
    const auto fitted = full.find(s.stamp_s);
    if (other == plain.end() || fitted == full.end()) continue;
    const auto k = static_cast<Eigen::Index>(std::llround(s.stamp_s - start));
    const Eigen::Vector3d field = h.pair().field_nT.row(k).transpose();
    sum_with += (s.field_nT - field).cwiseAbs2();
    sum_without += (other->second - field).cwiseAbs2();
    sum_full += (fitted->second - field).cwiseAbs2();
    ++compared;
  }
  ASSERT_GT(compared, 3600u) << "fewer than an hour of samples corrected by both nodes";
  const Eigen::Vector3d rms_with = (sum_with / static_cast<double>(compared)).cwiseSqrt();
  const Eigen::Vector3d rms_without = (sum_without / static_cast<double>(compared)).cwiseSqrt();
  const Eigen::Vector3d rms_full = (sum_full / static_cast<double>(compared)).cwiseSqrt();
  std::printf("[ temperature ] %zu samples: rms error without temperature %.3f %.3f %.3f nT, with a (apparent) "
              "%.3f %.3f %.3f nT, with c and s (full) %.3f %.3f %.3f nT\n",
              compared, rms_without(0), rms_without(1), rms_without(2), rms_with(0), rms_with(1), rms_with(2),
              rms_full(0), rms_full(1), rms_full(2));
  EXPECT_LT(rms_with.norm(), rms_without.norm());
  EXPECT_LT(rms_full.norm(), rms_without.norm());

  // Diagnostics: the channel's thermometer and the correction node's counters.
  const DiagnosticRecord* calibration = h.latest_diagnostic("calibration_sim: sim");
  ASSERT_NE(calibration, nullptr);
  EXPECT_EQ(calibration->values.at("temperature topic"), temperature_topic);
  EXPECT_EQ(value_of(calibration, "temperature samples"), n);
  EXPECT_EQ(value_of(calibration, "windows with temperature terms"), 1u);
  EXPECT_NE(calibration->values.at("temperature apparent coefficients (nT/degC)").find("degC"), std::string::npos);
  const DiagnosticRecord* corrected = h.latest_diagnostic("correction_sim");
  ASSERT_NE(corrected, nullptr);
  EXPECT_EQ(corrected->values.at("calibration temperature terms"), "fitted");
  EXPECT_EQ(corrected->values.at("temperature model"), "apparent");
  // Every sample is corrected with or without a recent temperature (~temperature_max_age 3600 s
  // of stamps, 1.44 s of wall time at ~rate 2500 samples per wall second: the two topics'
  // connections once drifted 0.4 s apart beside a busy CI run); most with one.
  const std::size_t with_temperature = value_of(corrected, "corrected with temperature");
  const std::size_t stale = value_of(corrected, "corrected without temperature, none recent");
  std::printf("[ temperature ] correction_sim: %zu corrected with temperature, %zu without (none recent)\n",
              with_temperature, stale);
  EXPECT_EQ(with_temperature + stale, value_of(corrected, "published"));
  EXPECT_GT(with_temperature, 9 * stale);
  const DiagnosticRecord* uncorrected = h.latest_diagnostic("correction_plain");
  ASSERT_NE(uncorrected, nullptr);
  EXPECT_EQ(uncorrected->values.at("temperature topic"), "none");
  std::remove(file.c_str());
}
