// rostest_calibration, nominal.test (Calibration.Nominal): accepted calibrations within their
// standard errors of n_true, the offset within its interval, the YAML file, the corrected stream
// equal to the clean field in absolute level, every raw sample accounted for under a burst, and
// correction nodes started from malformed / half-written calibration files.
#include "calibration_harness.hpp"
#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"
#include "magnetometer_insitu_calibration/preprocessing/despike.hpp"
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"

#include <Eigen/LU>

#include <algorithm>
#include <cstdio>

using namespace calibration_rostest;

namespace {

// 3 h 20 min of pairs at 1 Hz (~rate samples per wall second): windows of 3 h every 10 min ->
// windows starting at t0 and t0 + 600 s. Then a burst of 5000 test samples alone, as fast as
// the test can publish them, into the correction nodes (the load measurement: none dropped).
constexpr double kWindow_s = 10800.0, kStep_s = 600.0;
constexpr std::size_t kPairedSamples = 12000, kBurst = 5000;

/// The run's wall-clock times (s) and whether each phase finished in time.
struct NominalRun {
  ros::WallTime started;
  double publish_wall_s = 0.0, burst_wall_s = 0.0, burst_done_s = 0.0;
  bool paired_done = false, done = false;
};

/// Whether every corrected topic has a sample stamped stamp_s (UNIX s) or later.
bool corrected_reach(Harness& h, const std::vector<std::string>& topics, double stamp_s) {
  for (const std::string& topic : topics) {
    const auto& c = h.corrected(topic);
    if (c.empty() || c.back().stamp_s < stamp_s) return false;
  }
  return true;
}

/// Publishes the pairs and waits until both windows are estimated and in use by the correction
/// nodes, then the burst of test samples alone as fast as the test can publish them, and waits
/// until the corrected streams reach the last stamp and the nodes have counted every sample
/// (the clock keeps ticking for their diagnostics).
NominalRun publish_pairs_then_burst(Harness& h, const std::vector<std::string>& corrected_topics) {
  NominalRun run;
  run.started = ros::WallTime::now();
  const std::size_t n = h.pair().reference.size();
  h.publish(0, kPairedSamples, true, true);
  run.publish_wall_s = (ros::WallTime::now() - run.started).toSec();
  run.paired_done = h.wait([&] {
    return h.calibrations().size() >= 2 &&
           corrected_reach(h, corrected_topics, h.pair().reference.time_s[kPairedSamples - 1]);
  }, kPatience_s);
  const ros::WallTime burst_started = ros::WallTime::now();
  h.publish(kPairedSamples, n, false, true, 0.0, /*rate=*/0.0);
  run.burst_wall_s = (ros::WallTime::now() - burst_started).toSec();
  const double last_stamp = h.pair().reference.time_s.back();
  run.done = run.paired_done &&
             h.wait([&] { return corrected_reach(h, corrected_topics, last_stamp); }, kPatience_s) &&
             h.wait_ticking([&] {
               for (const char* node : {"correction_sim", "correction_malformed", "correction_truncated"}) {
                 if (value_of(h.latest_diagnostic(node), "received") != n) return false;
               }
               return true;
             }, kPatience_s);
  run.burst_done_s = (ros::WallTime::now() - burst_started).toSec();
  return run;
}

void print_timing(const NominalRun& run) {
  std::printf("[ timing ] published %zu pairs in %.2f s wall (%.0f samples/s per stream); burst of %zu test samples "
              "in %.3f s (%.0f samples/s), all corrected %.2f s after its start; total %.2f s\n",
              kPairedSamples, run.publish_wall_s, kPairedSamples / run.publish_wall_s, kBurst, run.burst_wall_s,
              kBurst / run.burst_wall_s, run.burst_done_s, (ros::WallTime::now() - run.started).toSec());
}

/// The filled samples each of `windows` windows should report. The node despikes each stream as
/// calibrate_records despikes each record (~despike, default on): the epochs it leaves without
/// a complete pair are those despike() flags in the records.
std::vector<std::size_t> expected_filled_samples(const mic::SimulatedPair& pair, std::size_t windows) {
  mic::Readings reference_despiked = pair.reference.values_nT.topRows(kPairedSamples);
  mic::Readings test_despiked = pair.test.values_nT.topRows(kPairedSamples);
  mic::despike(reference_despiked, mic::DespikeSettings{});
  mic::despike(test_despiked, mic::DespikeSettings{});
  std::vector<std::size_t> filled(windows, 0);
  for (std::size_t w = 0; w < windows; ++w) {
    const auto first = static_cast<std::size_t>(w * kStep_s);
    for (std::size_t i = first; i < first + 10800; ++i) {
      const auto r = static_cast<Eigen::Index>(i);
      filled[w] += !(reference_despiked.row(r).allFinite() && test_despiked.row(r).allFinite());
    }
  }
  return filled;
}

/// Window i's message: accepted, names and frames, its span, samples, period (s), band (Hz),
/// harmonics, gamma and trend column.
void check_window(const mic::MagnetometerCalibration& c, std::size_t i, Harness& h, std::size_t filled_samples) {
  EXPECT_TRUE(c.accepted);
  EXPECT_EQ(c.quality, mic::MagnetometerCalibration::QUALITY_OK) << c.quality_text;
  EXPECT_EQ(c.test_name, "sim");
  EXPECT_EQ(c.reference_frame_id, "reference_frame");
  EXPECT_EQ(c.header.frame_id, "reference_frame");
  EXPECT_EQ(c.test_frame_id, "test_frame");
  EXPECT_DOUBLE_EQ(c.window_start.toSec(), h.start_s() + i * kStep_s);
  EXPECT_DOUBLE_EQ(c.window_end.toSec(), h.start_s() + i * kStep_s + kWindow_s - 1.0);
  EXPECT_EQ(c.samples, 10800u);
  EXPECT_EQ(c.filled_samples, filled_samples);
  EXPECT_DOUBLE_EQ(c.sample_period, 1.0);
  EXPECT_DOUBLE_EQ(c.band_low_hz, 0.0002);
  EXPECT_DOUBLE_EQ(c.band_high_hz, 0.01);
  EXPECT_EQ(c.harmonic_first, 3u);    // ceil(0.0002 * 10800)
  EXPECT_EQ(c.harmonic_last, 108u);   // floor(0.01 * 10800)
  EXPECT_DOUBLE_EQ(c.gamma, 1.0);
  EXPECT_TRUE(c.trend_column);
}

/// n near n_true (truth_bound: nine entries exceeding it with probability below 1e-6), the covariance's cells and quantile, scale ratios,
/// coherence, the other parameters finite, the condition number. Returns max |n - n_true| / se.
double check_matrix(const mic::MagnetometerCalibration& c, Harness& h) {
  const Eigen::Matrix3d n_hat = matrix_of(c), se = stderr_of(c), n_true = h.pair().n_true;
  for (int k = 0; k < 9; ++k) {
    EXPECT_GT(se(k / 3, k % 3), 0.0);
    EXPECT_LE(std::abs(n_hat(k / 3, k % 3) - n_true(k / 3, k % 3)),
              truth_bound(c, 9) * c.interval_quantile * se(k / 3, k % 3))
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
                truth_bound(c, 3) * c.scale_ratio_ci95[l] + 1e-12);
    EXPECT_GT(c.coherence[l], 0.9);
    EXPECT_TRUE(std::isfinite(c.misalignment_deg[l]) && std::isfinite(c.nonorthogonality_deg[l]) &&
                std::isfinite(c.axis_deviation_deg[l]) && std::isfinite(c.trend_ci95_nT_per_day[l]));
  }
  EXPECT_GT(c.condition_number, 1.0);
  return ((n_hat - n_true).cwiseAbs().array() / se.array()).maxCoeff();
}

/// The offline CLI's estimator, its band and delay (s); the offset at the window end (nT) near
/// the simulated one (truth_bound).
void check_delay_and_offset(const mic::MagnetometerCalibration& c, std::size_t i, const mic::SimulationSettings& sim) {
  EXPECT_EQ(c.method, "robust");
  EXPECT_GE(c.band_used_low_hz, 0.0002 - 1e-12);
  EXPECT_LE(c.band_used_high_hz, 0.01 + 1e-12);
  EXPECT_GT(c.band_used_high_hz, c.band_used_low_hz);
  EXPECT_TRUE(std::isfinite(c.delay_s) && c.delay_ci95_s > 0.0) << c.delay_s << " +- " << c.delay_ci95_s;
  EXPECT_LE(std::abs(c.delay_s), truth_bound(c, 1) * c.delay_ci95_s) << "simulated delay is 0";
  for (int l = 0; l < 3; ++l) {
    EXPECT_GT(c.offset_ci95_nT[l], 0.0);
    EXPECT_LE(std::abs(c.offset_nT[l] - sim.test_offset_nT(l)), truth_bound(c, 3) * c.offset_ci95_nT[l])
        << "offset " << l << ": " << c.offset_nT[l] << " +- " << c.offset_ci95_nT[l];
  }
  std::printf("[ result ] window %zu: delay %.3f +- %.3f s, offset %.3f %.3f %.3f nT (+- %.3f %.3f %.3f), set %.0f %.0f %.0f\n",
              i, c.delay_s, c.delay_ci95_s, c.offset_nT[0], c.offset_nT[1], c.offset_nT[2], c.offset_ci95_nT[0],
              c.offset_ci95_nT[1], c.offset_ci95_nT[2], sim.test_offset_nT(0), sim.test_offset_nT(1), sim.test_offset_nT(2));
}

/// 1. Calibrations: two windows, accepted, within 4 standard errors of n_true.
void check_calibrations(Harness& h, const mic::SimulationSettings& sim) {
  const auto& calibrations = h.calibrations();
  ASSERT_EQ(calibrations.size(), 2u);
  const std::vector<std::size_t> filled = expected_filled_samples(h.pair(), calibrations.size());
  for (std::size_t i = 0; i < calibrations.size(); ++i) {
    const auto& c = calibrations[i];
    SCOPED_TRACE("calibration " + std::to_string(i));
    check_window(c, i, h, filled[i]);
    const double worst = check_matrix(c, h);
    check_delay_and_offset(c, i, sim);
    std::printf("[ result ] window %zu: max |n - n_true| / se = %.2f, se(n_xx) = %.2e\n", i, worst, stderr_of(c)(0, 0));
  }
}

/// 2. The YAML file holds the latest accepted calibration and loads back equal.
void check_calibration_file(const std::string& file, const mic::MagnetometerCalibration& latest) {
  mic::MagnetometerCalibration loaded;
  ASSERT_NO_THROW(loaded = mic::load_calibration_file(file));
  std::string difference;
  EXPECT_TRUE(mic::calibrations_equal(loaded, latest, &difference)) << "differs in " << difference;
}

/// 3a. Corrected stream: nothing before the first calibration, then every sample (no drop), in
///     the reference frame. Each corrected sample is r = n^-T (t - d) with the matrix and the
///     offset d (at its window end) of one of the published calibrations (the one in use: they
///     switch in order, once); it equals the clean field B within its published covariance.
///     errors[c]: corrected minus clean field (nT) of the samples corrected with calibration c.
void match_corrected(Harness& h, const std::vector<CorrectedSample>& out,
                     std::vector<std::vector<Eigen::Vector3d>>& errors) {
  const auto& calibrations = h.calibrations();
  const std::size_t n = h.pair().reference.size();
  ASSERT_GT(out.size(), 100u);
  EXPECT_GT(out.front().stamp_s, calibrations.front().window_end.toSec()) << "corrected data before any calibration existed";
  const auto first_index = static_cast<std::size_t>(std::llround(out.front().stamp_s - h.start_s()));
  EXPECT_EQ(out.size(), n - first_index) << "corrected samples missing after the first one";
  std::vector<Eigen::Matrix3d> inverse_transposed;
  std::vector<Eigen::Vector3d> offsets;
  for (const auto& c : calibrations) {
    inverse_transposed.push_back(matrix_of(c).inverse().transpose());
    offsets.emplace_back(c.offset_nT[0], c.offset_nT[1], c.offset_nT[2]);
  }
  errors.assign(calibrations.size(), {});
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
}

/// 3b. While one calibration is in use, the corrected stream is B itself in absolute level: the
///     mean difference within 4 noise sigma / sqrt(samples) plus the offset's stated 95 %
///     half-width, the scatter about it within 1.5 x the simulated test noise.
void check_corrected_level(Harness& h, const std::vector<CorrectedSample>& out,
                           const std::vector<std::vector<Eigen::Vector3d>>& errors) {
  const auto& calibrations = h.calibrations();
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
}

/// 4. Every raw sample is accounted for by the correction node (`published` of them corrected);
///    the calibration node's counters.
void check_sample_accounting(Harness& h, std::size_t published) {
  const std::size_t n = h.pair().reference.size();
  const DiagnosticRecord* d = h.latest_diagnostic("correction_sim");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(value_of(d, "received"), n);
  EXPECT_EQ(value_of(d, "published"), published);
  EXPECT_EQ(value_of(d, "dropped, no calibration"), n - published);
  EXPECT_EQ(d->values.at("calibration source").rfind("topic", 0), 0u);
  // The file calibration_node wrote is seen too (not "missing" from the start any longer).
  EXPECT_EQ(d->values.at("calibration file state").rfind("loaded", 0), 0u) << d->values.at("calibration file state");
  EXPECT_NE(d->values.at("calibration window").find("T"), std::string::npos);
  const DiagnosticRecord* cal = h.latest_diagnostic("calibration_sim: sim");
  ASSERT_NE(cal, nullptr);
  EXPECT_EQ(value_of(cal, "windows accepted"), 2u);
  // The despiker holds the reference stream's last 2 x 15 samples: it never sees their successors.
  EXPECT_EQ(value_of(cal, "paired"), kPairedSamples - 30);
  EXPECT_EQ(value_of(cal, "late") + value_of(cal, "duplicates"), 0u);
  // The response model ran on each window (~response_model, default on) and, the simulated pair
  // having matched filters, removed none.
  EXPECT_EQ(cal->values.at("response model (last window)").rfind("response model to ", 0), 0u)
      << cal->values.at("response model (last window)");
  EXPECT_EQ(value_of(cal, "windows estimated through a modelled filter"), 0u);
}

/// 5. Correction nodes started with a malformed / half-written file: an error in the
///    diagnostics, nothing published until a calibration arrives on the topic, then correcting.
void check_bad_file_nodes(Harness& h) {
  const std::size_t n = h.pair().reference.size();
  const double first_calibrated = h.calibrations().front().window_end.toSec();
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

/// 6. The verdicts against the tolerances (INTERMAGNET's, the default): nine in the last
///    message, each as its own value, interval and tolerance say; the test's tolerances status
///    at the worst one's level (OK within, WARN undecided, ERROR outside), at least WARN when
///    the message says the pair-only window is not vouched for.
void check_verdicts(Harness& h) {
  const mic::MagnetometerCalibration& last = h.calibrations().back();
  ASSERT_EQ(last.verdicts.size(), 9u);
  int worst = 0;
  for (const auto& v : last.verdicts) {
    const double d = std::abs(v.value - v.nominal);
    const char* expected = d + v.ci95 <= v.tolerance ? "within" : d - v.ci95 > v.tolerance ? "outside" : "undecided";
    EXPECT_EQ(v.verdict, expected) << v.parameter;
    worst = std::max(worst, v.verdict == "outside" ? 2 : v.verdict == "undecided" ? 1 : 0);
  }
  EXPECT_EQ(last.verdicts[0].parameter, "scale_x");
  EXPECT_DOUBLE_EQ(last.verdicts[0].value, last.scale_ratio[0]);
  EXPECT_DOUBLE_EQ(last.verdicts[0].ci95, last.scale_ratio_ci95[0]);
  EXPECT_DOUBLE_EQ(last.verdicts[0].tolerance, 0.01);
  EXPECT_EQ(last.verdicts[8].parameter, "misalignment_z");
  const DiagnosticRecord* t = h.latest_diagnostic("calibration_sim: sim tolerances");
  ASSERT_NE(t, nullptr);
  // The pair-only window's doubt (local_events.test) reaches the status exactly when the message
  // carries it; the 3-hour windows are long enough for the local-event check.
  EXPECT_TRUE(std::isfinite(last.local_events_p_value));
  const bool doubted = last.local_events_seen || last.band_split_differs;
  EXPECT_EQ(t->message.find("verdicts not vouched for") != std::string::npos, doubted) << t->message;
  EXPECT_EQ(t->level, doubted ? std::max(worst, 1) : worst) << t->message;
  EXPECT_EQ(t->values.count("non-orthogonality (last window)"), 1u);
}

}  // namespace

TEST(Calibration, Nominal) {
  mic::SimulationSettings sim = simulation(static_cast<double>(kPairedSamples + kBurst), 7);
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

  const NominalRun run = publish_pairs_then_burst(h, {corrected, bad_file_topics[0], bad_file_topics[1]});
  // A last round of diagnostics, published after the nodes saw everything above.
  EXPECT_TRUE(h.wait_fresh_diagnostics({"correction_sim", "correction_malformed", "correction_truncated",
                                        "calibration_sim: sim"}, 30.0))
      << "no diagnostics after the burst";
  std::lock_guard<std::mutex> lock(h.mutex());
  EXPECT_TRUE(run.paired_done) << "timed out waiting for the calibrations";
  EXPECT_TRUE(run.done) << "timed out waiting for the corrected burst";
  print_timing(run);

  ASSERT_NO_FATAL_FAILURE(check_calibrations(h, sim));
  ASSERT_NO_FATAL_FAILURE(check_calibration_file(file, h.calibrations().back()));
  const auto& out = h.corrected(corrected);
  std::vector<std::vector<Eigen::Vector3d>> errors;
  ASSERT_NO_FATAL_FAILURE(match_corrected(h, out, errors));
  check_corrected_level(h, out, errors);
  ASSERT_NO_FATAL_FAILURE(check_sample_accounting(h, out.size()));
  check_bad_file_nodes(h);
  check_verdicts(h);
}
