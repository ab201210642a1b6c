// simulate_records, run as a user runs it: records and truth match the library, bad options
// are named. Needs the executable's path from the build
// (SIMULATE_RECORDS_BIN="$<TARGET_FILE:simulate_records>").
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "magnetometer_insitu_calibration/simulation/station_disturbances.hpp"
#include "magnetometer_insitu_calibration/simulation/unmodelled_disturbances.hpp"
#include "magnetometer_insitu_calibration/formats/csv_record.hpp"
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <string>

namespace mic = magnetometer_insitu_calibration;

#ifdef SIMULATE_RECORDS_BIN
namespace {
using mic::test::ProgramRun;
using magnetometer_insitu_calibration::test::read_json;
ProgramRun run_simulate_records(const std::string& args) {
  return mic::test::run_program(SIMULATE_RECORDS_BIN, args);
}
}  // namespace
#endif

TEST(SimulateRecordsCli, WritesRecordsAndTruthMatchingTheLibrary) {
#ifndef SIMULATE_RECORDS_BIN
  GTEST_SKIP() << "SIMULATE_RECORDS_BIN not defined by the build";
#else
  const std::string dir = mic::test::make_temp_dir("simulate_records");
  const ProgramRun r = run_simulate_records(
      "--out-dir " + dir + " --format csv --days 0.25 --rate 1 --seed 9 --scale 0.999,1.001,1.002 "
      "--nonorthogonality-deg 0.1,0,-0.05 --misalignment-deg 0.2,0.1,-0.3 --noise-nT 0.02,0.03 "
      "--drift-nT-per-day 1,-2,3 --spikes-per-day 8 --gaps 2 --gap-seconds 60 --delay-s 0.02 "
      "--decimals 6");
  ASSERT_EQ(r.status, 0) << r.output;
  mic::SimulationSettings s;
  s.duration_s = 0.25 * 86400.0;
  s.seed = 9;
  s.scale_ratio = Eigen::Vector3d(0.999, 1.001, 1.002);
  s.nonorthogonality_deg = Eigen::Vector3d(0.1, 0.0, -0.05);
  s.misalignment_deg = Eigen::Vector3d(0.2, 0.1, -0.3);
  s.reference_white_nT = 0.02;
  s.test_white_nT = 0.03;
  s.drift_nT_per_day = Eigen::Vector3d(1, -2, 3);
  s.spikes_per_day = 8;
  s.gap_count = 2;
  s.gap_length_s = 60;
  s.delay_s = 0.02;
  const mic::SimulatedPair expected = mic::simulate_pair(s);
  const mic::VectorRecord reference = mic::read_csv_record(dir + "/reference.csv");
  const mic::VectorRecord test = mic::read_csv_record(dir + "/test.csv");
  ASSERT_EQ(reference.size(), expected.reference.size());
  ASSERT_EQ(test.size(), expected.test.size());
  EXPECT_NEAR(test.time_s.back(), expected.test.time_s.back(), 1e-6);
  for (Eigen::Index i = 0; i < test.values_nT.rows(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const double a = test.values_nT(i, c), b = expected.test.values_nT(i, c);
      ASSERT_EQ(std::isnan(a), std::isnan(b)) << "row " << i;
      if (!std::isnan(a)) ASSERT_NEAR(a, b, 6e-7) << "row " << i;
      const double ar = reference.values_nT(i, c), br = expected.reference.values_nT(i, c);
      ASSERT_EQ(std::isnan(ar), std::isnan(br)) << "row " << i;
      if (!std::isnan(ar)) ASSERT_NEAR(ar, br, 6e-7) << "row " << i;
    }
  }
  const nlohmann::json truth = read_json(dir + "/truth.json");
  for (int k = 0; k < 9; ++k) EXPECT_EQ(truth["n_true"][k].get<double>(), expected.n_true(k / 3, k % 3));
  EXPECT_EQ(truth["trend_nT_per_day"][1].get<double>(), -2.0);
  EXPECT_EQ(truth["spikes"].size(), 2u);
  EXPECT_EQ(truth["gaps"].size(), 2u);
  EXPECT_EQ(truth["settings"]["delay_s"].get<double>(), 0.02);

  // IAGA-2002: values at 0.01 nT.
  const ProgramRun iaga = run_simulate_records("--out-dir " + dir + "/iaga --days 0.05 --seed 9");
  ASSERT_EQ(iaga.status, 0) << iaga.output;
  const mic::VectorRecord ref_iaga = mic::read_iaga2002(dir + "/iaga/reference.iaga");
  EXPECT_EQ(ref_iaga.size(), 4320u);
  EXPECT_EQ(ref_iaga.station, "SIM");
#endif
}

TEST(SimulateRecordsCli, BadOptionsAreNamedAndFail) {
#ifndef SIMULATE_RECORDS_BIN
  GTEST_SKIP() << "SIMULATE_RECORDS_BIN not defined by the build";
#else
  const std::string dir = mic::test::make_temp_dir("simulate_records_bad");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--format xml", "--format"},
      {"--scale 1,2", "--scale"},
      {"--noise-nT 0.1,x", "--noise-nT"},
      {"--rate 0", "--rate"},
      {"--gaps 100 --gap-seconds 3600", "--gaps"},
      {"--nonorthogonality-deg 89,89,-89", "--nonorthogonality-deg"},
      {"--delay-s 1e9", "--delay-s"},
      {"--test-corner-hz -1", "--test-corner-hz"},
      {"--pier-tilt-walk-nT -0.1", "--pier-tilt-walk-nT"},
      {"--heater-nT 0,0", "--heater-nT"},
      {"--heater-period-s 0 --heater-nT 0,0.1,0", "--heater-period-s"},
      {"--road-distance-m 0.1 --vehicles-per-day 10", "--road-distance-m"},
      {"--z-ratio -1", "--z-ratio"},
      {"--remote --remote-incoherent 1.5", "--remote-incoherent"},
      {"--remote --remote-z-incoherent 1", "--remote-z-incoherent"},
      {"--remote --remote-z-incoherent x", "--remote-z-incoherent"},
      {"--remote --remote-coherence-corner-hz 0", "--remote-coherence-corner-hz"},
  };
  for (const auto& [args, option] : cases) {
    const ProgramRun r = run_simulate_records("--out-dir " + dir + " " + args);
    EXPECT_NE(r.status, 0) << args;
    EXPECT_NE(r.output.find(option), std::string::npos) << args << " -> " << r.output;
  }
#endif
}

// The disturbances the estimators do not model, from the command line: the records are the
// library's simulate_pair + add_station_disturbances + add_unmodelled_disturbances with the same
// settings, and truth.json states them.
TEST(SimulateRecordsCli, DisturbedStationOptionsMatchTheLibrary) {
#ifndef SIMULATE_RECORDS_BIN
  GTEST_SKIP() << "SIMULATE_RECORDS_BIN not defined by the build";
#else
  const std::string dir = mic::test::make_temp_dir("simulate_records_disturbed");
  const ProgramRun r = run_simulate_records(
      "--out-dir " + dir + " --format csv --days 0.2 --seed 4 --decimals 6 --z-ratio 0.2 "
      "--vehicles-per-day 200 --road-distance-m 30 --parking-probability 0.1 --pier-tilt-walk-nT 0.3 "
      "--heater-nT 0,0.05,-0.02 --heater-period-s 1200 --test-corner-hz 0.2 --test-delay-s 0.5 --gaps 1 "
      "--spikes-per-day 20");
  ASSERT_EQ(r.status, 0) << r.output;
  mic::SimulationSettings s;
  s.duration_s = 0.2 * 86400.0;
  s.seed = 4;
  s.variation_z_ratio = 0.2;
  s.gap_count = 1;
  s.spikes_per_day = 20;
  mic::SimulatedPair expected = mic::simulate_pair(s);
  const mic::VectorRecord clean_test = expected.test;
  mic::StationDisturbanceSettings d;
  d.seed = 4;
  d.vehicles_per_day = 200;
  d.road_distance_m = 30;
  d.parking_probability = 0.1;
  mic::add_station_disturbances(expected, d);
  mic::UnmodelledDisturbanceSettings u;
  u.seed = 4;
  u.tilt_walk_nT_per_sqrt_day = 0.3;
  u.heater_nT = Eigen::Vector3d(0.0, 0.05, -0.02);
  u.heater_period_s = 1200;
  u.test_corner_hz = 0.2;
  u.test_delay_s = 0.5;
  mic::add_unmodelled_disturbances(expected, u);
  const mic::VectorRecord test = mic::read_csv_record(dir + "/test.csv");
  ASSERT_EQ(test.size(), expected.test.size());
  double largest_change = 0.0;
  for (Eigen::Index i = 0; i < test.values_nT.rows(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const double a = test.values_nT(i, c), b = expected.test.values_nT(i, c);
      ASSERT_EQ(std::isnan(a), std::isnan(b)) << "row " << i;
      if (std::isnan(a)) continue;
      ASSERT_NEAR(a, b, 6e-7) << "row " << i;
      largest_change = std::max(largest_change, std::abs(a - clean_test.values_nT(i, c)));
    }
  }
  EXPECT_GT(largest_change, 0.05);  // the options did something
  const nlohmann::json truth = read_json(dir + "/truth.json");
  EXPECT_EQ(truth["test_only"]["test_corner_hz"].get<double>(), 0.2);
  EXPECT_EQ(truth["test_only"]["pier_tilt_walk_nT_per_sqrt_day"].get<double>(), 0.3);
  EXPECT_EQ(truth["traffic"]["vehicles_per_day"].get<double>(), 200.0);
#endif
}
