// rostest_calibration, nominal.test (Calibration.Nominal): accepted calibrations within their
// standard errors of n_true, the offset within its interval, the YAML file, the corrected stream
// equal to the clean field in absolute level, every raw sample accounted for under a burst, and
// correction nodes started from malformed / half-written calibration files.
#include "calibration_harness.hpp"
#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"
#include "magnetometer_insitu_calibration/preprocessing/despike.hpp"
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"

#include <Eigen/LU>

#include <cstdio>

using namespace calibration_rostest;

TEST(Calibration, Nominal) {
  // 3 h 20 min of pairs at 1 Hz (~rate samples per wall second): windows of 3 h every 10 min ->
  // windows starting at t0 and t0 + 600 s. Then a burst of 5000 test samples alone, as fast as
  // the test can publish them, into the correction nodes (the load measurement: none dropped).
  const double window_s = 10800.0, step_s = 600.0;
  const std::size_t paired_samples = 12000, burst = 5000;
  mic::SimulationSettings sim = simulation(static_cast<double>(paired_samples + burst), 7);
  sim.test_offset_nT = Eigen::Vector3d(120.0, -75.0, 30.0);  // baseline of the test: the offset transfer
  Harness h(sim);
  const std::string corrected = param("corrected_topic", "/sim/corrected");
  const std::vector<std::string> bad_file_topics = {"/sim/corrected_malformed", "/sim/corrected_truncated"};
  h.subscribe_corrected(corrected);
  for (const auto& t : bad_file_topics) h.subscribe_corrected(t);
  const std::string file = param("calibration_file");
  ASSERT_FALSE(file.empty());
  std::remove(file.c_str());
  ASSERT_TRUE(h.wait_for_connections(1, 4)) << "nodes did not connect";

  const ros::WallTime started = ros::WallTime::now();
  const std::size_t n = h.pair().reference.size();
  h.publish(0, paired_samples, true, true);
  const double publish_wall_s = (ros::WallTime::now() - started).toSec();
  // Both windows estimated and in use by the correction nodes before the burst.
  const bool paired_done = h.wait([&] {
    if (h.calibrations().size() < 2) return false;
    for (const std::string& topic : {corrected, bad_file_topics[0], bad_file_topics[1]}) {
      const auto& c = h.corrected(topic);
      if (c.empty() || c.back().stamp_s < h.pair().reference.time_s[paired_samples - 1]) return false;
    }
    return true;
  }, 30.0);
  const ros::WallTime burst_started = ros::WallTime::now();
  h.publish(paired_samples, n, false, true, 0.0, /*rate=*/0.0);
  const double burst_wall_s = (ros::WallTime::now() - burst_started).toSec();
  // Everything processed: the corrected streams reached the last stamp, and the correction
  // nodes have counted every sample (the clock keeps ticking for their diagnostics).
  const double last_stamp = h.pair().reference.time_s.back();
  const bool done = paired_done && h.wait([&] {
    for (const std::string& topic : {corrected, bad_file_topics[0], bad_file_topics[1]}) {
      const auto& c = h.corrected(topic);
      if (c.empty() || c.back().stamp_s < last_stamp) return false;
    }
    return true;
  }, 30.0) && h.wait_ticking([&] {
    for (const char* node : {"correction_sim", "correction_malformed", "correction_truncated"}) {
      if (value_of(h.latest_diagnostic(node), "received") != n) return false;
    }
    return true;
  }, 30.0);
  const double burst_done_s = (ros::WallTime::now() - burst_started).toSec();
  // A last round of diagnostics, published after the nodes saw everything above.
  EXPECT_TRUE(h.wait_fresh_diagnostics({"correction_sim", "correction_malformed", "correction_truncated",
                                        "calibration_sim: sim"}, 30.0))
      << "no diagnostics after the burst";
  std::lock_guard<std::mutex> lock(h.mutex());
  EXPECT_TRUE(paired_done) << "timed out waiting for the calibrations";
  EXPECT_TRUE(done) << "timed out waiting for the corrected burst";
  std::printf("[ timing ] published %zu pairs in %.2f s wall (%.0f samples/s per stream); burst of %zu test samples "
              "in %.3f s (%.0f samples/s), all corrected %.2f s after its start; total %.2f s\n",
              paired_samples, publish_wall_s, paired_samples / publish_wall_s, burst, burst_wall_s, burst / burst_wall_s,
              burst_done_s, (ros::WallTime::now() - started).toSec());

  // 1. Calibrations: two windows, accepted, within 4 standard errors of n_true.
  const auto& calibrations = h.calibrations();
  ASSERT_EQ(calibrations.size(), 2u);
  // The node despikes each stream as calibrate_records despikes each record (~despike, default
  // on): the epochs it leaves without a complete pair are those despike() flags in the records.
  mic::Readings reference_despiked = h.pair().reference.values_nT.topRows(paired_samples);
  mic::Readings test_despiked = h.pair().test.values_nT.topRows(paired_samples);
  mic::despike(reference_despiked, mic::DespikeSettings{});
  mic::despike(test_despiked, mic::DespikeSettings{});
  const auto flagged_epochs = [&](std::size_t first, std::size_t count) {
    std::size_t flagged = 0;
    for (std::size_t i = first; i < first + count; ++i) {
      const auto r = static_cast<Eigen::Index>(i);
      flagged += !(reference_despiked.row(r).allFinite() && test_despiked.row(r).allFinite());
    }
    return flagged;
  };
  for (std::size_t i = 0; i < calibrations.size(); ++i) {
    const auto& c = calibrations[i];
    SCOPED_TRACE("calibration " + std::to_string(i));
    EXPECT_TRUE(c.accepted);
    EXPECT_EQ(c.quality, mic::MagnetometerCalibration::QUALITY_OK) << c.quality_text;
    EXPECT_EQ(c.test_name, "sim");
    EXPECT_EQ(c.reference_frame_id, "reference_frame");
    EXPECT_EQ(c.header.frame_id, "reference_frame");
    EXPECT_EQ(c.test_frame_id, "test_frame");
    EXPECT_DOUBLE_EQ(c.window_start.toSec(), h.start_s() + i * step_s);
    EXPECT_DOUBLE_EQ(c.window_end.toSec(), h.start_s() + i * step_s + window_s - 1.0);
    EXPECT_EQ(c.samples, 10800u);
    EXPECT_EQ(c.filled_samples, flagged_epochs(static_cast<std::size_t>(i * step_s), 10800));
    EXPECT_DOUBLE_EQ(c.sample_period, 1.0);
    EXPECT_DOUBLE_EQ(c.band_low_hz, 0.0002);
    EXPECT_DOUBLE_EQ(c.band_high_hz, 0.01);
    EXPECT_EQ(c.harmonic_first, 3u);    // ceil(0.0002 * 10800)
    EXPECT_EQ(c.harmonic_last, 108u);   // floor(0.01 * 10800)
    EXPECT_DOUBLE_EQ(c.gamma, 1.0);
    EXPECT_TRUE(c.trend_column);
    const Eigen::Matrix3d n_hat = matrix_of(c), se = stderr_of(c), n_true = h.pair().n_true;
    for (int k = 0; k < 9; ++k) {
      EXPECT_GT(se(k / 3, k % 3), 0.0);
      EXPECT_LE(std::abs(n_hat(k / 3, k % 3) - n_true(k / 3, k % 3)), 4.0 * se(k / 3, k % 3))
          << "entry " << k << ": " << n_hat(k / 3, k % 3) << " vs n_true " << n_true(k / 3, k % 3) << ", se "
          << se(k / 3, k % 3);
    }
    // The covariance's cells (a 3-hour window: at most its 106 band harmonics) and the intervals'
    // Student quantile at them, as the offline estimator gives.
    EXPECT_GT(c.covariance_cells, 9.0);
    EXPECT_LE(c.covariance_cells, 106.0);
    EXPECT_DOUBLE_EQ(c.interval_quantile, mic::student_t_two_sided_quantile(0.05, c.covariance_cells));
    for (int l = 0; l < 3; ++l) {
      EXPECT_NEAR(c.scale_ratio[l], h.settings().scale_ratio(l),
                  4.0 * c.scale_ratio_ci95[l] / c.interval_quantile + 1e-12);
      EXPECT_GT(c.coherence[l], 0.9);
      EXPECT_TRUE(std::isfinite(c.misalignment_deg[l]) && std::isfinite(c.nonorthogonality_deg[l]) &&
                  std::isfinite(c.axis_deviation_deg[l]) && std::isfinite(c.trend_ci95_nT_per_day[l]));
    }
    EXPECT_GT(c.condition_number, 1.0);
    // The offline CLI's estimator, its band and delay; the offset at the window end.
    EXPECT_EQ(c.method, "robust");
    EXPECT_GE(c.band_used_low_hz, 0.0002 - 1e-12);
    EXPECT_LE(c.band_used_high_hz, 0.01 + 1e-12);
    EXPECT_GT(c.band_used_high_hz, c.band_used_low_hz);
    EXPECT_TRUE(std::isfinite(c.delay_s) && c.delay_ci95_s > 0.0) << c.delay_s << " +- " << c.delay_ci95_s;
    EXPECT_LE(std::abs(c.delay_s), 1.5 * c.delay_ci95_s) << "simulated delay is 0";
    for (int l = 0; l < 3; ++l) {
      EXPECT_GT(c.offset_ci95_nT[l], 0.0);
      EXPECT_LE(std::abs(c.offset_nT[l] - sim.test_offset_nT(l)), 1.5 * c.offset_ci95_nT[l])
          << "offset " << l << ": " << c.offset_nT[l] << " +- " << c.offset_ci95_nT[l];
    }
    std::printf("[ result ] window %zu: delay %.3f +- %.3f s, offset %.3f %.3f %.3f nT (+- %.3f %.3f %.3f), set %.0f %.0f %.0f\n",
                i, c.delay_s, c.delay_ci95_s, c.offset_nT[0], c.offset_nT[1], c.offset_nT[2], c.offset_ci95_nT[0],
                c.offset_ci95_nT[1], c.offset_ci95_nT[2], sim.test_offset_nT(0), sim.test_offset_nT(1), sim.test_offset_nT(2));
    std::printf("[ result ] window %zu: max |n - n_true| / se = %.2f, se(n_xx) = %.2e\n", i,
                ((n_hat - n_true).cwiseAbs().array() / se.array()).maxCoeff(), se(0, 0));
  }

  // 2. The YAML file holds the latest accepted calibration and loads back equal.
  mic::MagnetometerCalibration loaded;
  ASSERT_NO_THROW(loaded = mic::load_calibration_file(file));
  std::string difference;
  EXPECT_TRUE(mic::calibrations_equal(loaded, calibrations.back(), &difference)) << "differs in " << difference;

  // 3. Corrected stream: nothing before the first calibration, then every sample (no drop), in
  //    the reference frame. Each corrected sample is r = n^-T (t - d) with the matrix and the
  //    offset d (at its window end) of one of the published calibrations (the one in use: they
  //    switch in order, once); it equals the clean field B within its published covariance,
  //    and, while one calibration is in use, B itself in absolute level: the mean difference
  //    within 4 noise sigma / sqrt(samples) plus the offset's stated 95 % half-width, the
  //    scatter about it within 1.5 x the simulated test noise.
  const auto& out = h.corrected(corrected);
  ASSERT_GT(out.size(), 100u);
  const double first_calibrated = calibrations.front().window_end.toSec();
  EXPECT_GT(out.front().stamp_s, first_calibrated) << "corrected data before any calibration existed";
  const auto first_index = static_cast<std::size_t>(std::llround(out.front().stamp_s - h.start_s()));
  EXPECT_EQ(out.size(), n - first_index) << "corrected samples missing after the first one";
  std::vector<Eigen::Matrix3d> inverse_transposed;
  std::vector<Eigen::Vector3d> offsets;
  for (const auto& c : calibrations) {
    inverse_transposed.push_back(matrix_of(c).inverse().transpose());
    offsets.emplace_back(c.offset_nT[0], c.offset_nT[1], c.offset_nT[2]);
  }
  std::vector<std::vector<Eigen::Vector3d>> errors(calibrations.size());
  std::size_t outside = 0, unexplained = 0, in_use = 0;
  for (std::size_t i = 0; i < out.size(); ++i) {
    const auto k = static_cast<std::size_t>(std::llround(out[i].stamp_s - h.start_s()));
    ASSERT_LT(k, n);
    EXPECT_EQ(k, first_index + i);
    EXPECT_EQ(out[i].frame_id, "reference_frame");
    const Eigen::Vector3d t = h.pair().test.values_nT.row(k).transpose();
    std::size_t which = calibrations.size();
    for (std::size_t c = in_use; c < calibrations.size() && which == calibrations.size(); ++c) {
      if ((out[i].field_nT - inverse_transposed[c] * (t - offsets[c])).norm() < 1e-6) which = c;
    }
    if (which == calibrations.size()) {
      ++unexplained;
      continue;
    }
    in_use = which;
    const Eigen::Vector3d error = out[i].field_nT - h.pair().field_nT.row(k).transpose();
    for (int j = 0; j < 3; ++j) outside += std::abs(error(j)) > 5.0 * std::sqrt(out[i].covariance_nT2(j, j));
    errors[which].push_back(error);
  }
  EXPECT_EQ(unexplained, 0u) << "corrected samples that are not n^-T (t - d) for the calibration in use";
  EXPECT_EQ(outside, 0u) << "corrected values outside 5 sigma of their published covariance";
  for (std::size_t c = 0; c < errors.size(); ++c) {
    if (errors[c].empty()) continue;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero(), rms = Eigen::Vector3d::Zero();
    for (const auto& e : errors[c]) mean += e;
    mean /= static_cast<double>(errors[c].size());
    for (const auto& e : errors[c]) rms += (e - mean).cwiseAbs2();
    rms = (rms / static_cast<double>(errors[c].size())).cwiseSqrt();
    for (int j = 0; j < 3; ++j) {
      EXPECT_LT(rms(j), 1.5 * h.test_noise_rms_nT()(j)) << "calibration " << c << ", component " << j;
      const double allowed = 4.0 * h.test_noise_rms_nT()(j) / std::sqrt(static_cast<double>(errors[c].size())) +
                             calibrations[c].offset_ci95_nT[j];
      EXPECT_LE(std::abs(mean(j)), allowed) << "calibration " << c << ", component " << j
                                            << ": corrected minus clean field, mean " << mean(j) << " nT";
      // The stated interval of d alone is wide (mean field x se(n)), but d's error and n's cancel
      // near the window's field: the absolute level is far better than that (the set baseline
      // is 30-120 nT; without the offset the mean difference would be about that).
      EXPECT_LT(std::abs(mean(j)), 1.0) << "calibration " << c << ", component " << j;
    }
    std::printf("[ result ] %zu samples corrected with calibration %zu: offset %.2f %.2f %.2f nT "
                "(1 sigma %.2f %.2f %.2f nT), rms about it %.4f %.4f %.4f nT (test noise %.4f %.4f %.4f nT)\n",
                errors[c].size(), c, mean(0), mean(1), mean(2), std::sqrt(out.back().covariance_nT2(0, 0)),
                std::sqrt(out.back().covariance_nT2(1, 1)), std::sqrt(out.back().covariance_nT2(2, 2)), rms(0), rms(1),
                rms(2), h.test_noise_rms_nT()(0), h.test_noise_rms_nT()(1), h.test_noise_rms_nT()(2));
  }
  EXPECT_FALSE(errors.back().empty()) << "the latest calibration was never used";

  // 4. Every raw sample is accounted for by the correction node.
  const DiagnosticRecord* d = h.latest_diagnostic("correction_sim");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(value_of(d, "received"), n);
  EXPECT_EQ(value_of(d, "published"), out.size());
  EXPECT_EQ(value_of(d, "dropped, no calibration"), n - out.size());
  EXPECT_EQ(d->values.at("calibration source").rfind("topic", 0), 0u);
  EXPECT_NE(d->values.at("calibration window").find("T"), std::string::npos);
  const DiagnosticRecord* cal = h.latest_diagnostic("calibration_sim: sim");
  ASSERT_NE(cal, nullptr);
  EXPECT_EQ(value_of(cal, "windows accepted"), 2u);
  // The despiker holds the reference stream's last 2 x 15 samples: it never sees their successors.
  EXPECT_EQ(value_of(cal, "paired"), paired_samples - 30);
  EXPECT_EQ(value_of(cal, "late") + value_of(cal, "duplicates"), 0u);
  // The response model ran on each window (~response_model, default on) and, the simulated pair
  // having matched filters, removed none.
  EXPECT_EQ(cal->values.at("response model (last window)").rfind("response model to ", 0), 0u)
      << cal->values.at("response model (last window)");
  EXPECT_EQ(value_of(cal, "windows estimated through a modelled filter"), 0u);

  // 5. Correction nodes started with a malformed / half-written file: an error in the
  //    diagnostics, nothing published until a calibration arrives on the topic, then correcting.
  for (const std::string& node : {std::string("correction_malformed"), std::string("correction_truncated")}) {
    SCOPED_TRACE(node);
    bool error_seen = false;
    for (const DiagnosticRecord* r : h.all_diagnostics(node)) {
      error_seen |= r->level == 2 && r->message.find("calibration file unusable") != std::string::npos &&
                    r->message.find(".yaml") != std::string::npos;
    }
    EXPECT_TRUE(error_seen) << "no error diagnostic for the bad calibration file";
    const auto& bad = h.corrected("/sim/" + std::string(node == "correction_malformed" ? "corrected_malformed" : "corrected_truncated"));
    ASSERT_FALSE(bad.empty());
    EXPECT_GT(bad.front().stamp_s, first_calibrated);
    const DiagnosticRecord* last = h.latest_diagnostic(node);
    ASSERT_NE(last, nullptr);
    EXPECT_EQ(value_of(last, "received"), n) << "samples dropped under load";
    EXPECT_EQ(value_of(last, "published"), bad.size());
  }
}
