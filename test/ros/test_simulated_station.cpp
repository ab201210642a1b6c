// rostest (test/ros/test_simulated_station*.test, test_simulated_network.test): the whole
// simulated station end to end, launch/simulated_station.launch: two lemi025_simulator instances
// on pseudo-terminals (same seed, roles reference and test, faster than real time, a 6-hour
// record looped) -> two lemi025_driver -> calibration_node (10 Hz decimated to 1 Hz, short
// windows) -> correction_node.
//
// What each asserts is deterministic, whatever the machine's load or which packets a busy
// machine lost on the pseudo-terminals:
//  * the correction equals the calibration applied: every corrected sample is, to 1e-9 of its
//    magnitude, r = n^-T (t - d) (with a hut: t - d - a u, u the thermometer's reading minus
//    the window's mean) of the raw test sample t of the same stamp, with one of the accepted
//    calibrations, taken in the order they were published; computed here with Eigen from the
//    message's fields, not with the package's correction code;
//  * the accepted calibration carries the drivers' frame ids and quality ok;
//  * against the simulated truth only at bounds that fail by chance with probability below
//    1e-6 (each says how): n's nine entries, the scalar check's scale, the hut's coefficients.
// How well the estimates match the truth is measured by the Monte Carlo programs
// (docs/accuracy.md), not here.
// Each test waits for its condition (an accepted window, then `pairs` corrected samples); the
// simulators loop, so on a slow or loaded machine it takes longer instead of running out of
// record. `timeout` (wall s) is only the safety net of a broken chain.
//
// With `offline_node` (the calibration node's name), also:
//  * the first accepted window the test's records cover equals calibrate_records' path (its
//    pre-processing and per-window stage, with that node's settings) on the drivers' samples the
//    test recorded: n to 1e-9.
// Private parameters (strings): seed, offline_node, start (as given to the simulators), field_seed
// (simulated_network.launch shared_field: the field's seed, 0 = seed), remote ("true": every
// accepted calibration must have used the remote reference), scalar ("true": it must carry the
// scalar check of simulated_station.launch's scalar_simulator, the reference's scale 1), pairs
// (corrected samples to check per pair), timeout (s), hut_daily and hut_heater (the hut test),
// temperature_max_age (s, correction_node's); for SimulatedNetwork `network`, the pairs as
// STATION/TEST:SEED separated by spaces (topics /STATION/TEST/magnetic_field, /STATION/TEST/calibration,
// /STATION/TEST/corrected; frame ids STATION_reference, STATION_TEST as network.launch sets).
#include "station_offline_window.hpp"
#include "station_recorder.hpp"

#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"
#include "magnetometer_insitu_calibration/simulation/hut_temperature.hpp"
#include "magnetometer_insitu_calibration/simulation/lemi025_station.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <Eigen/LU>
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace {

using station_rostest::PairUnderTest;
using station_rostest::StationRecorder;
namespace mic = magnetometer_insitu_calibration;

std::string station_param(const std::string& name, const std::string& fallback) {
  std::string value;
  return ros::param::get("~" + name, value) ? value : fallback;
}

/// The simulators' record (lemi025_simulator: 10 Hz, a 6-hour record from `start`).
mic::SimulationSettings simulator_settings(std::uint64_t seed) {
  mic::SimulationSettings base;
  base.seed = seed;
  base.field_seed = std::stoull(station_param("field_seed", "0"));  // simulated_network.launch shared_field
  base.keep_clean_field = true;
  return mic::lemi025_station_settings(base, mic::parse_iso8601(station_param("start", "2025-05-13T23:55:00Z")),
                                       6 * 3600.0, 5.0);
}

Eigen::Matrix3d matrix_of(const mic::MagnetometerCalibration& c) {
  Eigen::Matrix3d n;
  for (int k = 0; k < 9; ++k) n(k / 3, k % 3) = c.matrix[static_cast<std::size_t>(k)];
  return n;
}

/// Every element of the accepted calibration near n_true, within the bound that the nine
/// together exceed with probability below 1e-6 (Bonferroni: each its two-sided 1.1e-7 quantile
/// of Student's t with the window's covariance_cells dof). Returns the largest |n - n_true| / se.
double expect_calibration_near_truth(const mic::MagnetometerCalibration& calibration, const Eigen::Matrix3d& n_true,
                                     const PairUnderTest& pair) {
  EXPECT_EQ(calibration.reference_frame_id, pair.reference_frame_id) << pair.label;
  EXPECT_EQ(calibration.test_frame_id, pair.test_frame_id) << pair.label;
  EXPECT_EQ(calibration.quality, mic::MagnetometerCalibration::QUALITY_OK) << pair.label << ": " << calibration.quality_text;
  const Eigen::Matrix3d n = matrix_of(calibration);
  const double bound = mic::student_t_two_sided_quantile(1e-6 / 9.0, calibration.covariance_cells);
  EXPECT_TRUE(std::isfinite(bound)) << pair.label << ": covariance_cells " << calibration.covariance_cells;
  double worst = 0.0;
  for (int k = 0; k < 9; ++k) {
    const double se = std::sqrt(calibration.matrix_covariance[static_cast<std::size_t>(10 * k)]);
    const double error = n(k / 3, k % 3) - n_true(k / 3, k % 3);
    worst = std::max(worst, std::abs(error) / se);
    EXPECT_GT(se, 0.0) << pair.label;
    EXPECT_LE(std::abs(error), bound * se) << pair.label << ": n(" << k / 3 << "," << k % 3 << ") = " << n(k / 3, k % 3)
                                         << ", true " << n_true(k / 3, k % 3) << ", standard error " << se;
  }
  std::fprintf(stderr, "%s: max |n - n_true| / se = %.2f (bound %.2f from %.1f cells)\n", pair.label.c_str(), worst,
               bound, calibration.covariance_cells);
  return worst;
}

/// correction_node's correction of the raw test sample t (nT, test frame) with calibration c
/// (its defaults: the offset applied, the apparent temperature model), at temperature_C (NaN:
/// without the temperature terms): r = n^-T (t - d - a u), u = temperature - the window's mean.
Eigen::Vector3d corrected_by(const mic::MagnetometerCalibration& c, const Eigen::Vector3d& t, double temperature_C) {
  Eigen::Vector3d y = t - Eigen::Vector3d(c.offset_nT[0], c.offset_nT[1], c.offset_nT[2]);
  if (c.temperature_fitted && std::isfinite(temperature_C)) {
    const double u = temperature_C - c.temperature_reference_C;
    for (int l = 0; l < 3; ++l) y(l) -= c.temperature_apparent_nT_per_C[static_cast<std::size_t>(l)] * u;
  }
  return matrix_of(c).transpose().fullPivLu().solve(y);
}

/// Every corrected sample whose raw test sample was recorded is that sample corrected with one
/// of the accepted calibrations (to 1e-9 of its magnitude), the calibrations used in the order
/// published; with a thermometer, at one of its readings within temperature_max_age of the
/// sample's stamp or, when none was that fresh, without the terms. Returns the samples checked.
std::size_t expect_correction_applies_calibration(StationRecorder& recorder, const PairUnderTest& pair) {
  std::vector<mic::MagnetometerCalibration> accepted;
  for (const auto& c : recorder.calibrations()) {
    if (c.accepted) accepted.push_back(c);
  }
  const auto test = recorder.test();
  const auto temperature = recorder.temperature();
  const auto max_age_ns = static_cast<std::uint64_t>(1e9 * std::stod(station_param("temperature_max_age", "10")));
  std::size_t checked = 0, used = 0, with_temperature = 0, mismatched = 0;
  for (const auto& [stamp, r] : recorder.corrected()) {
    const auto raw = test.find(stamp);
    if (raw == test.end()) continue;  // this recorder missed the raw sample
    std::vector<double> temperatures{std::numeric_limits<double>::quiet_NaN()};
    for (auto t = temperature.lower_bound(stamp > max_age_ns ? stamp - max_age_ns : 0);
         t != temperature.end() && t->first <= stamp + max_age_ns; ++t) {
      temperatures.push_back(t->second);
    }
    bool matched = false;
    for (std::size_t i = used; i < accepted.size() && !matched; ++i) {
      for (const double theta : temperatures) {
        if ((corrected_by(accepted[i], raw->second, theta) - r).norm() <= 1e-9 * r.norm()) {
          matched = true;
          used = i;
          with_temperature += std::isfinite(theta);
          break;
        }
      }
    }
    ++checked;
    if (!matched && ++mismatched <= 5) {
      ADD_FAILURE() << pair.label << ": the corrected sample at " << mic::format_iso8601(1e-9 * stamp, 1)
                    << " is no accepted calibration (from the " << used + 1 << "th on) applied to its raw sample";
    }
  }
  EXPECT_EQ(mismatched, 0u) << pair.label << ": of " << checked << " corrected samples checked";
  for (const std::string& frame : recorder.corrected_frame_ids()) EXPECT_EQ(frame, pair.reference_frame_id) << pair.label;
  std::fprintf(stderr, "%s: %zu corrected samples are the raw ones corrected with the accepted calibrations (%zu "
               "with the thermometer's terms; %zu calibrations used of %zu accepted)\n",
               pair.label.c_str(), checked, with_temperature, used + 1, accepted.size());
  return checked;
}

/// Waits (wall time, at most `timeout`: the safety net of a broken chain) until `ready` holds
/// for every recorder.
bool wait_for(std::vector<std::unique_ptr<StationRecorder>>& recorders, const std::function<bool(StationRecorder&)>& ready) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(std::stod(station_param("timeout", "300")));
  auto all = [&] {
    return std::all_of(recorders.begin(), recorders.end(), [&](const auto& r) { return ready(*r); });
  };
  while (ros::ok() && ros::WallTime::now() < deadline && !all()) ros::WallDuration(0.05).sleep();
  return all();
}

/// The first accepted calibration recorded (with temperature terms when `fitted`), if any.
bool first_accepted(StationRecorder& recorder, mic::MagnetometerCalibration& out, bool fitted = false) {
  for (const auto& c : recorder.calibrations()) {
    if (c.accepted && (!fitted || c.temperature_fitted)) {
      out = c;
      return true;
    }
  }
  return false;
}

/// The first accepted window of the pair that the test's records cover and that held the samples
/// the test received equals the offline path on them (compare_with_offline: calibrate_records'
/// pre-processing and per-window stage with the node's settings): n to 1e-9. Waits for the
/// next window while none is comparable (the test subscribed after a window's start, or missed
/// a sample the node received).
void expect_window_equals_offline(StationRecorder& recorder, const PairUnderTest& pair, const std::string& node) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(std::stod(station_param("timeout", "300")));
  std::size_t tried = 0;
  std::string why_not = "no accepted window";
  while (ros::ok() && ros::WallTime::now() < deadline) {
    const auto calibrations = recorder.calibrations();
    for (; tried < calibrations.size(); ++tried) {
      const mic::MagnetometerCalibration& c = calibrations[tried];
      if (!c.accepted) continue;
      const station_rostest::OfflineComparison o =
          station_rostest::compare_with_offline(c, node, recorder.reference(), recorder.test());
      if (!o.comparable) {
        why_not = mic::format_iso8601(c.window_start.toSec(), 0) + ": " + o.why_not;
        std::fprintf(stderr, "%s: window %s not compared\n", pair.label.c_str(), why_not.c_str());
        continue;
      }
      std::fprintf(stderr, "%s: window %s (%zu samples, %zu without data) equals the offline path's: max |n_live - n_offline| = %.2e\n",
                   pair.label.c_str(), mic::format_iso8601(c.window_start.toSec(), 0).c_str(), o.samples, o.filled,
                   o.largest_difference);
      EXPECT_LE(o.largest_difference, 1e-9) << pair.label;
      return;
    }
    ros::WallDuration(0.1).sleep();
  }
  ADD_FAILURE() << pair.label << ": no live window comparable with the offline path (last: " << why_not << ")";
}

/// Waits until every pair has an accepted calibration and `pairs` corrected samples recorded,
/// then checks each.
void check_pairs_live(const std::vector<PairUnderTest>& pairs) {
  const std::size_t wanted = std::stoul(station_param("pairs", "1000"));
  std::vector<std::unique_ptr<StationRecorder>> recorders;
  for (const auto& pair : pairs) recorders.push_back(std::make_unique<StationRecorder>(pair));
  const ros::WallTime started = ros::WallTime::now();
  mic::MagnetometerCalibration scratch;
  const bool ready = wait_for(recorders, [&](StationRecorder& r) {
    return first_accepted(r, scratch) && r.corrected_count() >= wanted;
  });
  std::fprintf(stderr, "%zu pair(s): ready %s after %.1f s (wall)\n", pairs.size(), ready ? "" : "NOT",
               (ros::WallTime::now() - started).toSec());
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    mic::MagnetometerCalibration calibration;
    if (!first_accepted(*recorders[i], calibration)) {
      ADD_FAILURE() << pairs[i].label << ": " << recorders[i]->calibrations().size() << " calibrations, none accepted";
      continue;
    }
    std::fprintf(stderr, "%s: first accepted window %s .. %s\n", pairs[i].label.c_str(),
                 mic::format_iso8601(calibration.window_start.toSec(), 0).c_str(),
                 mic::format_iso8601(calibration.window_end.toSec(), 0).c_str());
    expect_calibration_near_truth(calibration, mic::simulate_pair(simulator_settings(pairs[i].seed)).n_true, pairs[i]);
    if (station_param("scalar", "false") == "true") {  // scalar_simulator beside the reference
      // The simulated reference reads the field (scale 1). 3 of the check's 95 % half-widths are
      // exceeded by chance with probability below 1e-6 from 30 or more spectral cells (Student's
      // t: 6.1 / 2.04 standard errors at 30 dof).
      EXPECT_NE(calibration.scalar_text.find("reference scale along the field"), std::string::npos)
          << pairs[i].label << ": " << calibration.scalar_text;
      EXPECT_LE(std::abs(calibration.reference_scale_along_field - 1.0), 3.0 * calibration.reference_scale_along_field_ci95)
          << pairs[i].label << ": " << calibration.scalar_text;
    }
    if (station_param("remote", "false") == "true") {  // each station the other's remote reference
      EXPECT_TRUE(calibration.remote_used) << pairs[i].label << ": " << calibration.remote_text;
      // One field, no local disturbance: the pair alone is not biased (with the identified noise
      // level's uncertainty left out of the difference, a false call has p 1e-6 here).
      EXPECT_FALSE(calibration.pair_biased) << pairs[i].label << ": " << calibration.remote_text;
    }
    EXPECT_GE(expect_correction_applies_calibration(*recorders[i], pairs[i]), wanted / 2) << pairs[i].label;
    const std::string node = station_param("offline_node", "");
    if (!node.empty()) expect_window_equals_offline(*recorders[i], pairs[i], node);
  }
}

PairUnderTest station_pair(const std::string& label) {
  PairUnderTest pair;
  pair.label = label;
  pair.test_topic = "/test/magnetic_field";
  if (!station_param("offline_node", "").empty()) pair.reference_topic = "/reference/magnetic_field";
  pair.calibration_topic = "/test/calibration";
  pair.corrected_topic = "/test/corrected";
  pair.reference_frame_id = "lemi025_sim_reference";
  pair.test_frame_id = "lemi025_sim_test";
  pair.seed = std::stoull(station_param("seed", "1"));
  return pair;
}

TEST(SimulatedStation, CalibrationRecoversTruthAndCorrectionMatchesReference) {
  check_pairs_live({station_pair("simulated station")});
}

TEST(SimulatedStation, HutTemperatureThroughTheDrivers) {
  PairUnderTest pair = station_pair("hut");
  pair.temperature_topic = "/test/temperature/sensor";
  mic::HutTemperatureSettings hut;  // as lemi025_simulator --hut-* sets it: seed = --seed, default coefficients
  hut.seed = pair.seed;
  hut.daily_amplitude_C = std::stod(station_param("hut_daily", "0"));
  hut.heater_amplitude_C = std::stod(station_param("hut_heater", "0"));
  ASSERT_GT(hut.daily_amplitude_C + hut.heater_amplitude_C, 0.0) << "~hut_daily / ~hut_heater not set";
  const std::size_t wanted = std::stoul(station_param("pairs", "1000"));
  std::vector<std::unique_ptr<StationRecorder>> recorders;
  recorders.push_back(std::make_unique<StationRecorder>(pair));
  StationRecorder& recorder = *recorders.front();
  mic::MagnetometerCalibration calibration;
  wait_for(recorders, [&](StationRecorder& r) { return first_accepted(r, calibration, true) && r.corrected_count() >= wanted; });
  ASSERT_TRUE(first_accepted(recorder, calibration, true))
      << recorder.calibrations().size() << " calibrations, none accepted with temperature terms";
  std::fprintf(stderr, "hut: window %s .. %s: %s\n", mic::format_iso8601(calibration.window_start.toSec(), 0).c_str(),
               mic::format_iso8601(calibration.window_end.toSec(), 0).c_str(), calibration.temperature_text.c_str());

  // The truth: the simulators' record before the hut. a_l = c_l + s_l F_l, F the window's mean
  // test field without the hut (test frame, nT).
  const mic::SimulationSettings settings = simulator_settings(pair.seed);
  const mic::SimulatedPair clean = mic::simulate_pair(settings);
  const auto first = static_cast<Eigen::Index>(std::llround((calibration.window_start.toSec() - settings.start_time_s) / 0.1));
  const auto last = static_cast<Eigen::Index>(std::llround((calibration.window_end.toSec() - settings.start_time_s) / 0.1));
  ASSERT_GE(first, 0);
  ASSERT_LT(last, clean.test.values_nT.rows());
  const Eigen::Vector3d field = clean.test.values_nT.middleRows(first, last - first + 1).colwise().mean().transpose();
  // The three together exceed their bound with probability below 1e-6 (Bonferroni: Student's t
  // two-sided 3.3e-7 quantile with the window's dof; a standard error is ci95 / interval_quantile).
  const double bound = mic::student_t_two_sided_quantile(1e-6 / 3.0, calibration.covariance_cells) /
                       calibration.interval_quantile;
  for (int l = 0; l < 3; ++l) {
    const double truth = hut.offset_nT_per_C(l) + 1e-6 * hut.scale_ppm_per_C(l) * field(l);
    const double a = calibration.temperature_apparent_nT_per_C[static_cast<std::size_t>(l)];
    const double ci95 = calibration.temperature_apparent_ci95_nT_per_C[static_cast<std::size_t>(l)];
    std::fprintf(stderr, "hut: a_%d = %.4f +- %.4f nT/degC, simulated %.4f\n", l, a, ci95, truth);
    EXPECT_LE(std::abs(a - truth), bound * ci95) << "component " << l << ": a " << a << ", simulated " << truth;
  }
  // Corrected live with the terms: each sample the raw one corrected at a thermometer reading.
  EXPECT_GE(expect_correction_applies_calibration(recorder, pair), wanted / 2);
}

TEST(SimulatedNetwork, EveryPairRecoversTruthAndCorrects) {
  const std::string network = station_param("network", "");
  ASSERT_FALSE(network.empty()) << "private parameter ~network (STATION/TEST:SEED ...) not set";
  std::vector<PairUnderTest> pairs;
  std::istringstream words(network);
  for (std::string word; words >> word;) {
    const auto slash = word.find('/'), colon = word.find(':');
    ASSERT_TRUE(slash != std::string::npos && colon != std::string::npos && slash < colon) << "bad ~network entry " << word;
    const std::string station = word.substr(0, slash), test = word.substr(slash + 1, colon - slash - 1);
    PairUnderTest pair;
    pair.label = station + "/" + test;
    pair.test_topic = "/" + station + "/" + test + "/magnetic_field";
    pair.calibration_topic = "/" + station + "/" + test + "/calibration";
    pair.corrected_topic = "/" + station + "/" + test + "/corrected";
    pair.reference_frame_id = station + "_reference";
    pair.test_frame_id = station + "_" + test;
    pair.seed = std::stoull(word.substr(colon + 1));
    pairs.push_back(pair);
  }
  check_pairs_live(pairs);
}

}  // namespace
