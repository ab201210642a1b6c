// rostest_calibration, what the input streams do to calibration_node:
//   Calibration.SilentTopic     silent_topic.test     test stream stops for 20 min
//   Calibration.TimeJump        time_jump.test        stamps jump forward by an hour; correction
//                                                     policy for another frame_id / old stamps
//   Calibration.Decimation10Hz  decimation.test       10 Hz inputs decimated to 1 Hz in the node
//   Calibration.TwoInstruments  two_instruments.test  a ~tests list: two test instruments, one node
//   Calibration.ThreeCorneredHat three_cornered_hat.test  two tests of different noise: the
//                                                     reference's noise identified per window
#include "calibration_harness.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/simulation/co_located_instrument.hpp"
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"

#include <cmath>
#include <cstdio>

using namespace calibration_rostest;

TEST(Calibration, SilentTopic) {
  // Windows of 30 min every 5 min. The test stream stops from t0 + 2400 s to t0 + 3600 s.
  const double silent_first = 2400.0, silent_end = 3600.0;
  Harness h(simulation(7000.0, 11));
  ASSERT_TRUE(h.wait_for_connections(1, 2)) << "nodes did not connect";
  const double t0 = h.start_s();
  h.publish(0, 2400, true, true);
  h.publish(2400, 3600, true, false);  // test topic silent for 20 min (reference and /clock go on)
  // The silence shows in the diagnostics while it lasts (silent_timeout 300 s, diagnostics every
  // 5 s; a timeout much shorter than the arrival skew of the topics at 2500x real time, about
  // 0.1 s wall = 250 s simulated, would also warn about the reference now and then).
  EXPECT_TRUE(h.wait([&] {
    for (const DiagnosticRecord* r : h.all_diagnostics("calibration_sim: sim")) {
      if (r->level == 1 && r->message.find("test topic silent") != std::string::npos) return true;
    }
    return false;
  }, kPatience_s)) << "no silence warning";
  {
    std::lock_guard<std::mutex> lock(h.mutex());
    const DiagnosticRecord* reference = h.latest_diagnostic("calibration_sim: reference");
    ASSERT_NE(reference, nullptr);
    EXPECT_EQ(reference->level, 0) << reference->message;
  }
  h.publish(3600, 7000, true, true);
  const double last_window_start = t0 + 5100.0;  // [5100, 6900): the last complete window
  EXPECT_TRUE(h.wait([&] {
    return !h.calibrations().empty() && h.calibrations().back().window_start.toSec() >= last_window_start;
  }, kPatience_s));
  EXPECT_TRUE(h.wait_fresh_diagnostics({"calibration_sim: sim"}, 20.0));

  std::lock_guard<std::mutex> lock(h.mutex());
  std::size_t accepted_before = 0, flagged_across = 0, accepted_after = 0;
  for (const auto& c : h.calibrations()) {
    const double start = c.window_start.toSec() - t0;
    if (overlaps(c, t0 + silent_first, t0 + silent_end - 1.0)) {
      EXPECT_FALSE(c.accepted) << "window starting at t0 + " << start << " s accepted across the silence";
      EXPECT_EQ(c.quality, mic::MagnetometerCalibration::QUALITY_GAPS) << c.quality_text;
      EXPECT_GT(c.filled_samples, 0u);
      ++flagged_across;
    } else if (c.window_end.toSec() < t0 + silent_first) {
      accepted_before += c.accepted;
    } else {
      accepted_after += c.accepted;
    }
  }
  // Windows starting 900..3300 s overlap the silence (the ones wholly inside it have no data: skipped).
  EXPECT_EQ(flagged_across, 9u);
  EXPECT_EQ(accepted_before, 3u);  // [0, 1800), [300, 2100), [600, 2400)
  EXPECT_EQ(accepted_after, 6u);   // [3600, 5400) .. [5100, 6900)
  const DiagnosticRecord* cal = h.latest_diagnostic("calibration_sim: sim");
  ASSERT_NE(cal, nullptr);
  EXPECT_EQ(cal->message.find("silent"), std::string::npos) << "still silent after the stream resumed";
  EXPECT_GT(value_of(cal, "unpaired reference"), 1000u);
  EXPECT_EQ(value_of(cal, "windows skipped (no data)"), 0u);
}

// ---------------------------------------------------------------------------------------------

TEST(Calibration, TimeJump) {
  // Both streams' stamps jump forward by one hour at t0 + 2400 s (the clock does not).
  const double jump_s = 3600.0;
  Harness h(simulation(4831.0, 13));  // 30 s more: the despiker's delay
  h.subscribe_corrected(param("corrected_topic", "/sim/corrected"));
  ASSERT_TRUE(h.wait_for_connections(1, 2)) << "nodes did not connect";
  const double t0 = h.start_s();
  h.publish(0, 2400, true, true);
  // Every sample before the jump reaches the node before any after it: otherwise one stream's
  // samples still in transit when the other's stamps are already an hour ahead would find their
  // partners aged out (StreamPairer ages samples in stamp time), as many as the connections lag.
  ASSERT_TRUE(h.wait_received({{"calibration_sim: reference", "messages", 2400}, {"calibration_sim: sim", "test messages", 2400}}))
      << "the samples before the jump did not all reach the node";
  h.publish(2400, 4831, true, true, jump_s);  // stamps t0 + 6000 .. t0 + 8430
  // The last window, and the correction node through the stream's last sample: it corrects in
  // order, so every corrected sample of the stream is in before the policy's ten samples below.
  const std::string corrected = param("corrected_topic", "/sim/corrected");
  const double last_stamp = h.pair().reference.time_s[4830] + jump_s;
  EXPECT_TRUE(h.wait([&] {
    return !h.calibrations().empty() && h.calibrations().back().window_start.toSec() >= t0 + 6600.0 &&
           !h.corrected(corrected).empty() && h.corrected(corrected).back().stamp_s >= last_stamp;
  }, kPatience_s));
  EXPECT_TRUE(h.wait_fresh_diagnostics({"calibration_sim: reference", "calibration_sim: sim"}, 20.0));

  {
  std::lock_guard<std::mutex> lock(h.mutex());
  std::size_t accepted_before = 0, flagged_across = 0, accepted_after = 0;
  for (const auto& c : h.calibrations()) {
    if (overlaps(c, t0 + 2400.0, t0 + 2400.0 + jump_s - 1.0)) {
      EXPECT_FALSE(c.accepted) << "window " << c.window_start.toSec() - t0 << " s spanning the jump accepted";
      ++flagged_across;
    } else if (c.window_end.toSec() < t0 + 2400.0) {
      accepted_before += c.accepted;
    } else {
      accepted_after += c.accepted;
    }
  }
  EXPECT_EQ(accepted_before, 3u);   // [0, 1800) .. [600, 2400)
  EXPECT_GE(flagged_across, 10u);   // [900, 2700) .. [2100, 3900) and [4500, 6300) .. [5700, 7500)
  EXPECT_EQ(accepted_after, 3u);    // [6000, 7800), [6300, 8100), [6600, 8400)
  const DiagnosticRecord* reference = h.latest_diagnostic("calibration_sim: reference");
  const DiagnosticRecord* test = h.latest_diagnostic("calibration_sim: sim");
  ASSERT_NE(reference, nullptr);
  ASSERT_NE(test, nullptr);
  EXPECT_EQ(value_of(reference, "stamp jumps forward"), 1u);
  EXPECT_EQ(value_of(test, "test stamp jumps forward"), 1u);
  // Of the 4831 samples of each stream, the despiker holds the last 2 x 15 (never paired). Around
  // the jump only the 30 each despiker held when its stream's stamps jumped can lose their
  // partners: they reach the pairer after that stream's first jumped samples, and a burst of the
  // other stream's jumped samples ages them out (StreamPairer ages in stamp time, 600 s). Every
  // raw sample before the jump reached the node before any after it (wait_received above), so no
  // other sample can.
  std::printf("[ result ] paired %zu, unpaired reference %zu, unpaired test %zu\n", value_of(test, "paired"),
              value_of(test, "unpaired reference"), value_of(test, "unpaired test"));
  EXPECT_LE(value_of(test, "unpaired reference"), 30u);
  EXPECT_LE(value_of(test, "unpaired test"), 30u);
  EXPECT_EQ(value_of(test, "paired") + value_of(test, "unpaired test"), 4831u - 30u);
  // The correction node went on across the jump.
  const auto& out = h.corrected(corrected);
  ASSERT_FALSE(out.empty());
  EXPECT_GE(out.back().stamp_s, t0 + 8400.0);
  }

  // Correction policy, with the last calibration (window t0 + 6600 .. 8399 s) in use:
  // 5 samples of another frame_id are not corrected (counted); 5 samples stamped before the
  // window are corrected with it (counted); neither disturbs the calibration node beyond a
  // stray stamp and, for the second old sample in a row, a restart of its pairing.
  std::size_t corrected_before = 0, received_before = 0;
  {
    std::lock_guard<std::mutex> lock(h.mutex());
    corrected_before = h.corrected(corrected).size();
    received_before = value_of(h.latest_diagnostic("correction_sim"), "received");
  }
  for (std::size_t k = 0; k < 5; ++k) h.publish_test_sample(4000 + k, t0 + 8401.0 + k, "another_frame");
  for (std::size_t k = 0; k < 5; ++k) h.publish_test_sample(100 + k, t0 + 100.0 + k, "test_frame");
  // Wait on the counters the ten samples move. The node's "received" in the last diagnostic may
  // still lag the stream's final samples (diagnostics go out once a second), so it is only
  // required to have grown by at least ten.
  EXPECT_TRUE(h.wait_ticking([&] {
    const DiagnosticRecord* d = h.latest_diagnostic("correction_sim");
    return value_of(d, "dropped, frame_id mismatch") == 5 && value_of(d, "corrected, before window") == 5 &&
           value_of(d, "received") >= received_before + 10 && h.corrected(corrected).size() == corrected_before + 5;
  }, kPatience_s));
  std::lock_guard<std::mutex> lock(h.mutex());
  const DiagnosticRecord* d = h.latest_diagnostic("correction_sim");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(value_of(d, "dropped, frame_id mismatch"), 5u);
  EXPECT_EQ(value_of(d, "corrected, before window"), 5u);
  const auto& out = h.corrected(corrected);
  ASSERT_EQ(out.size(), corrected_before + 5);
  for (std::size_t i = corrected_before; i < out.size(); ++i) {
    EXPECT_DOUBLE_EQ(out[i].stamp_s, t0 + 100.0 + (i - corrected_before));
    EXPECT_EQ(out[i].frame_id, "reference_frame");
  }
}

// ---------------------------------------------------------------------------------------------

namespace {

/// The node's two 30-minute windows (every 5 min, the first at t0 + 300 s: the filter's first
/// output comes 3.9 s after the first sample) against the per-window stage on the offline
/// preparation of the same records: the same samples and n, and n near the truth (truth_bound).
void expect_offline_windows(Harness& h, const mic::PreparedPair& prepared, const char* label) {
  const double t0 = h.start_s();
  mic::WindowCalibrator calibrator{mic::WindowCalibrationSettings{}};
  std::lock_guard<std::mutex> lock(h.mutex());
  ASSERT_EQ(h.calibrations().size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const auto& c = h.calibrations()[i];
    SCOPED_TRACE("calibration " + std::to_string(i));
    EXPECT_TRUE(c.accepted) << c.quality_text;
    EXPECT_DOUBLE_EQ(c.window_start.toSec(), t0 + 300.0 * (i + 1));
    EXPECT_DOUBLE_EQ(c.sample_period, 1.0);
    const std::size_t first = static_cast<std::size_t>(std::llround(c.window_start.toSec() - prepared.paired.time_s[0]));
    const mic::CalibrationWindow o = calibrator.calibrate(mic::window_records(prepared, first, 1800, 60.0));
    EXPECT_EQ(c.samples, o.estimate.samples);
    EXPECT_EQ(c.filled_samples, o.missing());
    for (int k = 0; k < 9; ++k) EXPECT_NEAR(c.matrix[k], o.estimate.n(k / 3, k % 3), 1e-7) << "entry " << k;
    const Eigen::Matrix3d n_hat = matrix_of(c), se = stderr_of(c), n_true = h.pair().n_true;
    for (int k = 0; k < 9; ++k) {
      EXPECT_LE(std::abs(n_hat(k / 3, k % 3) - n_true(k / 3, k % 3)), truth_bound(c, 9) * c.interval_quantile * se(k / 3, k % 3))
          << "entry " << k;
    }
    std::printf("[ result ] %s window %zu: max |n - n_true| / se = %.2f\n", label, i,
                ((n_hat - n_true).cwiseAbs().array() / se.array()).maxCoeff());
  }
}

}  // namespace

TEST(Calibration, Decimation10Hz) {
  // 10 Hz inputs (input_period 0.1 s), low-passed and decimated to 1 Hz in calibration_node;
  // windows of 30 min every 5 min. The decimator's first output comes h = 3.9 s after the first
  // sample, so the first window starts at t0 + 300 s.
  Harness h(simulation(2500.0, 17, 0.1));
  ASSERT_TRUE(h.wait_for_connections(1, 1)) << "nodes did not connect";
  const ros::WallTime started = ros::WallTime::now();
  const std::size_t n = h.pair().reference.size();
  h.publish(0, n, true, true);
  const double publish_wall_s = (ros::WallTime::now() - started).toSec();
  EXPECT_TRUE(h.wait([&] { return h.calibrations().size() >= 2; }, kPatience_s));
  EXPECT_TRUE(h.wait_fresh_diagnostics({"calibration_sim: sim"}, 20.0));
  std::printf("[ timing ] published %zu pairs at 10 Hz in %.2f s wall (%.0f samples/s per stream)\n", n, publish_wall_s,
              n / publish_wall_s);

  // The offline preparation of the same records (despiked at 10 Hz, paired, decimated to 1 Hz)
  // and the per-window stage on the same windows: the node's windows are those.
  const mic::PreparedPair prepared = mic::prepare_pair(h.pair().reference, h.pair().test, mic::PreprocessSettings{});
  expect_offline_windows(h, prepared, "10 Hz");
  std::lock_guard<std::mutex> lock(h.mutex());
  const DiagnosticRecord* cal = h.latest_diagnostic("calibration_sim: sim");
  ASSERT_NE(cal, nullptr);
  EXPECT_EQ(cal->values.at("epoch alignment"), "paired_then_decimated");
  // The despiker holds each stream's last 2 x 15 samples: they are never paired.
  EXPECT_EQ(value_of(cal, "paired"), n - 30);
}

// ---------------------------------------------------------------------------------------------

TEST(Calibration, OneSecondReferenceBesideATenHertzTest) {
  // An observatory's 1 s reference beside a 10 Hz test (~input_period 1, ~test_input_period 0.1):
  // calibration_node low-passes each stream onto whole seconds before pairing, as calibrate_records
  // prepares records of two rates; its windows are those of the offline preparation.
  Harness h(simulation(2500.0, 17, 0.1));
  h.publish_reference_every(10);  // the simulation's samples at whole seconds
  h.add_test_copy("/sim/test_apart/magnetic_field", "test_frame", 10, 3);  // 1 s, 0.3 s after them
  ASSERT_TRUE(h.wait_for_connections(1, 1)) << "nodes did not connect";
  ASSERT_TRUE(h.wait([&] { return h.test_subscribers(0) >= 1; }, kPatience_s));
  ASSERT_DOUBLE_EQ(std::fmod(h.start_s(), 300.0), 0.0);
  const std::size_t n = h.pair().reference.size();
  h.publish(0, n, true, true);
  EXPECT_TRUE(h.wait([&] { return h.calibrations().size() >= 2; }, kPatience_s));
  EXPECT_TRUE(h.wait_fresh_diagnostics(
      {"calibration_sim: sim", "calibration_sim: reference", "calibration_wrong: wrong", "calibration_apart: apart"}, 20.0));

  mic::VectorRecord reference = h.pair().reference;  // its samples 0, 10, 20, ...: whole seconds
  const Eigen::Index count = (static_cast<Eigen::Index>(n) + 9) / 10;
  reference.time_s.resize(static_cast<std::size_t>(count));
  reference.values_nT.resize(count, 3);
  for (Eigen::Index i = 0; i < count; ++i) {
    reference.time_s[static_cast<std::size_t>(i)] = h.pair().reference.time_s[static_cast<std::size_t>(10 * i)];
    reference.values_nT.row(i) = h.pair().reference.values_nT.row(10 * i);
  }
  mic::PreprocessReport report;
  const mic::PreparedPair prepared = mic::prepare_pair(reference, h.pair().test, mic::PreprocessSettings{}, &report);
  ASSERT_EQ(report.alignment, mic::EpochAlignment::kEachFiltered);
  expect_offline_windows(h, prepared, "1 s reference, 10 Hz test");
  std::lock_guard<std::mutex> lock(h.mutex());
  const DiagnosticRecord* cal = h.latest_diagnostic("calibration_sim: sim");
  ASSERT_NE(cal, nullptr);
  EXPECT_EQ(cal->values.at("epoch alignment"), "each_filtered");
  // Each stream's period measured on its stamps: those the parameters give, no error. The node
  // given no periods (the default 1 s for both) is told that the test's stamps step by 0.1 s.
  EXPECT_NEAR(std::stod(cal->values.at("test measured period (s)")), 0.1, 1e-4);
  EXPECT_EQ(cal->message.find("stamps step by"), std::string::npos) << cal->message;  // silent by now: WARN
  const DiagnosticRecord* reference_status = h.latest_diagnostic("calibration_sim: reference");
  ASSERT_NE(reference_status, nullptr);
  EXPECT_NEAR(std::stod(reference_status->values.at("measured period (s)")), 1.0, 1e-4);
  EXPECT_EQ(reference_status->message.find("stamps step by"), std::string::npos) << reference_status->message;
  const DiagnosticRecord* wrong = h.latest_diagnostic("calibration_wrong: wrong");
  ASSERT_NE(wrong, nullptr);
  EXPECT_EQ(wrong->level, 2);
  EXPECT_NE(wrong->message.find("test 'wrong' stamps step by 0.1 s, not 1 s (~test_input_period, else ~input_period)"),
            std::string::npos)
      << wrong->message;
  // A 1 s test stamped 0.3 s after the reference's seconds, paired by stamp: nothing pairs, and
  // the node says why.
  const DiagnosticRecord* apart = h.latest_diagnostic("calibration_apart: apart");
  ASSERT_NE(apart, nullptr);
  EXPECT_EQ(apart->level, 2);
  EXPECT_NE(apart->message.find("test 'apart' stamps fall +0.3 s off the reference's in each 1 s, beyond "
                                "~pairing_tolerance (0.01 s): nothing pairs; give ~stamps_apart true"),
            std::string::npos)
      << apart->message;
  EXPECT_EQ(apart->values.at("paired"), "0");
}

// ---------------------------------------------------------------------------------------------

TEST(Calibration, TwoInstruments) {
  // One calibration_node with a ~tests list of two instruments (the second one sees the same
  // simulated test readings under another frame_id): one calibration topic and file each.
  // 2431 s: the despiker holds each stream's last 30 samples; the third window needs its end.
  Harness h(simulation(2431.0, 19));
  h.add_test_copy("/sim/test_b/magnetic_field", "test_b_frame");
  h.subscribe_calibration("/sim/b/calibration");
  ASSERT_TRUE(h.wait_for_connections(1, 1)) << "nodes did not connect";
  ASSERT_TRUE(h.wait([&] { return h.test_subscribers(0) >= 1; }, kPatience_s));
  h.publish(0, 2431, true, true);
  EXPECT_TRUE(h.wait([&] {
    return h.calibrations().size() >= 3 && h.calibrations_of("/sim/b/calibration").size() >= 3;
  }, kPatience_s));
  std::lock_guard<std::mutex> lock(h.mutex());
  const auto& a = h.calibrations();
  const auto& b = h.calibrations_of("/sim/b/calibration");
  ASSERT_EQ(a.size(), 3u);  // [0, 1800), [300, 2100), [600, 2400)
  ASSERT_EQ(b.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_TRUE(a[i].accepted) << a[i].quality_text;
    EXPECT_TRUE(b[i].accepted) << b[i].quality_text;
    EXPECT_EQ(a[i].test_name, "a");
    EXPECT_EQ(b[i].test_name, "b");
    EXPECT_EQ(a[i].test_frame_id, "test_frame");
    EXPECT_EQ(b[i].test_frame_id, "test_b_frame");
    EXPECT_EQ(a[i].window_start, b[i].window_start);
    for (int k = 0; k < 9; ++k) EXPECT_EQ(a[i].matrix[k], b[i].matrix[k]);  // same data, same estimate
  }
  // Two tests: the three-cornered hat is on (one bin over the band in 30 min windows), but one
  // record on two topics has no noise of its own to tell apart: the hat identifies nothing and
  // says why, and each window falls back to the reference's noise from its own pair above the
  // band (the same data: the equal matrices above).
  const DiagnosticRecord* diag_a = h.latest_diagnostic("calibration_sim: a");
  ASSERT_NE(diag_a, nullptr);
  EXPECT_NE(diag_a->values.at("reference noise (last window)").find("one record twice"), std::string::npos)
      << diag_a->values.at("reference noise (last window)");
  EXPECT_EQ(diag_a->values.at("EIV (last window)").rfind("reference noise from the pair above the band: ", 0), 0u)
      << diag_a->values.at("EIV (last window)");
  for (const std::string& file : {param("file_a"), param("file_b")}) {
    SCOPED_TRACE(file);
    mic::MagnetometerCalibration loaded;
    ASSERT_NO_THROW(loaded = mic::load_calibration_file(file));
    EXPECT_EQ(loaded.window_start, a.back().window_start);
    std::remove(file.c_str());
  }
}

// ---------------------------------------------------------------------------------------------

namespace {

/// The reference's noise level (ASD, pT/sqrt(Hz) one-sided / sqrt(2 dt) = pT rms per sample for
/// white noise) over [low, high] Hz from the hat's text "white w/w/w pT rms, 1/f p/p/p pT/sqrt(Hz)",
/// per axis; NaN when the text has no such numbers.
Eigen::Vector3d identified_level_pT(const std::string& text, double low_hz, double high_hz) {
  double w[3], p[3];
  const std::size_t at = text.find("white ");
  if (at == std::string::npos ||
      std::sscanf(text.c_str() + at, "white %lf/%lf/%lf pT rms, 1/f %lf/%lf/%lf", &w[0], &w[1], &w[2], &p[0], &p[1], &p[2]) != 6) {
    return Eigen::Vector3d::Constant(std::nan(""));
  }
  const double inverse_f = std::log(high_hz / low_hz) / (high_hz - low_hz);  // mean of 1/f over the band
  Eigen::Vector3d level;
  for (int c = 0; c < 3; ++c) level(c) = std::sqrt(w[c] * w[c] + inverse_f * p[c] * p[c] / 2.0);  // dt = 1 s
  return level;
}

}  // namespace

TEST(Calibration, ThreeCorneredHat) {
  // One reference (white 100 pT, ten times the test's: it attenuates n), test 'a' (10 pT) and test
  // 'b' (50 pT, its own misalignment), on one calibration_node: every window identifies the
  // reference's noise from the three and corrects with it.
  // 7231 s: the despiker holds each stream's last 30 samples; the third window needs its end.
  mic::SimulationSettings s = simulation(7231.0, 23);
  s.reference_white_nT = 0.1;
  s.test_white_nT = 0.01;
  s.reference_pink_nT_per_sqrt_hz = s.test_pink_nT_per_sqrt_hz = 0.0;
  s.keep_clean_field = true;
  Harness h(s);
  h.add_test_instrument("/sim/test_b/magnetic_field", "test_b_frame",
                        mic::co_located_instrument(h.pair().field_nT, mic::co_located_instrument_matrix(), 0.05, 23));
  h.subscribe_calibration("/sim/b/calibration");
  ASSERT_TRUE(h.wait_for_connections(1, 1)) << "nodes did not connect";
  ASSERT_TRUE(h.wait([&] { return h.test_subscribers(0) >= 1; }, kPatience_s));
  h.publish(0, 7231, true, true);
  // Windows of 1 h every 30 min: [0, 3600), [1800, 5400), [3600, 7200).
  EXPECT_TRUE(h.wait([&] {
    return h.calibrations().size() >= 3 && h.calibrations_of("/sim/b/calibration").size() >= 3;
  }, kPatience_s));
  ASSERT_TRUE(h.wait_fresh_diagnostics({"calibration_sim: a", "calibration_sim: b"}, 10.0));
  std::lock_guard<std::mutex> lock(h.mutex());
  for (const std::string name : {"a", "b"}) {
    SCOPED_TRACE(name);
    const DiagnosticRecord* d = h.latest_diagnostic("calibration_sim: " + name);
    ASSERT_NE(d, nullptr);
    const std::string noise = d->values.at("reference noise (last window)");
    std::printf("[ result ] test %s: %s\n", name.c_str(), noise.c_str());
    EXPECT_NE(noise.find(name == "a" ? "with test 'b'" : "with test 'a'"), std::string::npos) << noise;
    EXPECT_EQ(value_of(d, "windows corrected with the hat's reference noise"), 3u);
    EXPECT_NE(d->values.at("EIV (last window)").find("three-cornered hat"), std::string::npos);
    EXPECT_NE(d->values.at("reference noise model").find("three-cornered hat"), std::string::npos);
    // 1 h windows hold one 3 h section at most: intervals from the frequency-group jackknife, and
    // the hat's levels carry their uncertainty into them.
    EXPECT_EQ(d->values.at("intervals (last window)"), "sandwich raised to the jackknife over 8 interleaved frequency groups, "
                                                       "plus the identified reference noise's uncertainty");
    EXPECT_EQ(d->values.at("weights (last window)"), "lambda^gamma x Huber cell x section");
    // The identified level against the simulated 100 pT, within 20 %.
    const Eigen::Vector3d level = identified_level_pT(noise, 0.002, 0.05);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(level(c) / 100.0, 1.0, 0.2) << c << ": " << noise;
  }
  // Test a's windows: the scale ratios of the simulation within truth_bound (the correction is
  // applied; without it a reference 10x noisier than the test attenuates the scale ratios by
  // several half-widths).
  const Eigen::Vector3d truth = mic::decompose(h.pair().n_true).scale_ratio;
  for (const auto& c : h.calibrations()) {
    EXPECT_TRUE(c.accepted) << c.quality_text;
    for (int k = 0; k < 3; ++k) {
      EXPECT_LT(std::abs(c.scale_ratio[k] - truth(k)), truth_bound(c, 3) * c.scale_ratio_ci95[k]) << "axis " << k;
    }
  }
}
