// Records in rosbags, without a master: the bag round trip (bag_records.hpp), records_to_bag on
// every input format (skipped records reported, temperatures, progress), calibrate_records
// --bag giving the JSON of calibrate_records on the files (the real WIC pair and a simulated
// 10 Hz LEMI pair), and export_corrected from a bag (with calibration_node's YAML file:
// test_bag_export.cpp, compiled with this file as one translation unit).
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/formats/imagcdf_writer.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "bag_records.hpp"  // src/program_support
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include "archive_fixtures.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <Eigen/LU>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <rosbag/bag.h>
#include <sensor_msgs/MagneticField.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <tuple>

namespace mic = magnetometer_insitu_calibration;

namespace {

using mic::test::make_temp_dir;
using mic::test::package_data;
using mic::test::ProgramRun;
using mic::test::run_program;

using mic::test::read_json;

/// Times equal, values within one unit in the last place (the tesla conversion), NaN kept.
void expect_same_record_to_one_ulp(const mic::VectorRecord& a, const mic::VectorRecord& b) {
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(a.time_s, b.time_s);
  std::size_t exact = 0, total = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const double x = a.values_nT(static_cast<Eigen::Index>(i), c), y = b.values_nT(static_cast<Eigen::Index>(i), c);
      if (std::isnan(x) || std::isnan(y)) {
        ASSERT_TRUE(std::isnan(x) && std::isnan(y)) << "sample " << i;
        continue;
      }
      ++total;
      exact += x == y;
      const double ulp = std::nextafter(std::abs(x), std::numeric_limits<double>::infinity()) - std::abs(x);
      ASSERT_LE(std::abs(x - y), ulp) << "sample " << i << " component " << c;
    }
  }
  EXPECT_GT(exact, total * 8 / 10) << "most values survive the tesla round trip bit for bit";
}

/// Two calibrate_records reports describe the same calibration: every window's labels, times,
/// counts, harmonics and quality equal; every number within `relative` (numerical noise of the
/// one-ulp tesla round trip of the inputs); the pre-processing counts equal. `a` is the bag's:
/// it names no components (a MagneticField has none) but its topics' frames, `b` the files'
/// components and no frames.
void expect_same_report(const nlohmann::json& a, const nlohmann::json& b, double relative) {
  ASSERT_EQ(a["windows"].size(), b["windows"].size());
  nlohmann::json counts_a = a["preprocessing"], counts_b = b["preprocessing"];
  for (const char* key : {"reference_components", "test_components"}) {
    EXPECT_TRUE(counts_a[key].is_null()) << key << " of a bag: " << counts_a[key];
    EXPECT_TRUE(counts_b[key].is_array() && counts_b[key].size() == 3u) << key << " of files: " << counts_b[key];
    counts_a.erase(key);
    counts_b.erase(key);
  }
  for (const char* key : {"reference_frame_id", "test_frame_id"}) {
    EXPECT_TRUE(counts_a[key].is_string() && !counts_a[key].get<std::string>().empty()) << key << " of a bag: " << counts_a[key];
    EXPECT_TRUE(counts_b[key].is_null()) << key << " of files: " << counts_b[key];
    counts_a.erase(key);
    counts_b.erase(key);
  }
  EXPECT_EQ(counts_a, counts_b);
  double worst = 0.0;
  std::string worst_at;
  std::function<void(const nlohmann::json&, const nlohmann::json&, const std::string&)> walk =
      [&](const nlohmann::json& x, const nlohmann::json& y, const std::string& at) {
        if (at.size() > 15 && at.compare(at.size() - 15, 15, ".response_model") == 0 && x.is_object()) {
          // The response model lowers its fit band at a chi^2/dof threshold: a one-ulp difference in
          // the inputs may stop the fit one band lower (seen: chi^2/dof 2.01 vs 1.84 on the WIC day),
          // which moves its fitted numbers but not what it decides about n.
          ASSERT_TRUE(y.is_object()) << at;
          EXPECT_EQ(x.at("fitted"), y.at("fitted")) << at;
          EXPECT_EQ(x.at("applied"), y.at("applied")) << at;
          for (std::size_t k = 0; k < 3; ++k) {  // a corner applied in both or in neither
            const nlohmann::json &u = x.at("corner_hz").at(k), &v = y.at("corner_hz").at(k);
            ASSERT_EQ(u.is_null(), v.is_null()) << at << ".corner_hz[" << k << "]";
            if (!u.is_null()) {
              EXPECT_NEAR(u.get<double>(), v.get<double>(), 1e-6 * u.get<double>()) << at;
            }
          }
          return;
        }
        if (x.is_number_float() || y.is_number_float()) {
          ASSERT_TRUE(x.is_number() && y.is_number()) << at;
          const double u = x.get<double>(), v = y.get<double>();
          const double d = std::abs(u - v) / std::max({std::abs(u), std::abs(v), 1e-300});
          if (d > worst) {
            worst = d;
            worst_at = at;
          }
        } else if (x.is_object()) {
          ASSERT_EQ(x.size(), y.size()) << at;
          for (auto it = x.begin(); it != x.end(); ++it) walk(it.value(), y.at(it.key()), at + "." + it.key());
        } else if (x.is_array()) {
          ASSERT_EQ(x.size(), y.size()) << at;
          for (std::size_t i = 0; i < x.size(); ++i) walk(x[i], y[i], at + "[" + std::to_string(i) + "]");
        } else {
          EXPECT_EQ(x, y) << at;
        }
      };
  walk(a["windows"], b["windows"], "windows");
  EXPECT_LE(worst, relative) << "largest relative difference at " << worst_at;
}

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace

// ---- the library ------------------------------------------------------------------------------

TEST(BagRecords, RoundTripKeepsTimesExactValuesToOneUlpGapsAndTemperatures) {
  const std::string dir = make_temp_dir("bag_roundtrip");
  mic::SimulationSettings s;
  s.duration_s = 7200.0;
  s.sample_period_s = 0.1;
  s.start_time_s = 1747180800.0 - 0.3;
  s.gap_count = 3;
  s.gap_length_s = 20.0;
  s.keep_clean_field = false;
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::BagTemperatureStream temperature{"/ref/sensor_temperature", "ref_frame", {}, {}};
  for (int j = 0; j < 7200; ++j) {
    temperature.time_s.push_back(1747180800.0 + j);
    temperature.celsius.push_back(21.0 + 0.01 * j);
  }
  std::vector<std::pair<std::size_t, std::size_t>> progress;
  const mic::BagWriteSummary summary = mic::write_records_bag(
      dir + "/pair.bag", {{"ref/field", "ref_frame", &pair.reference}, {"/tst/field", "tst_frame", &pair.test}},
      {temperature}, mic::BagCompression::kLz4,
      [&](std::size_t done, std::size_t total) { progress.emplace_back(done, total); });
  EXPECT_EQ(summary.messages, 2 * 72000u + 7200u);
  EXPECT_EQ(summary.per_topic.at("/ref/field"), 72000u);
  ASSERT_FALSE(progress.empty());
  EXPECT_EQ(progress.back(), std::make_pair(summary.messages, summary.messages));

  std::vector<std::string> warnings;
  const std::vector<mic::VectorRecord> back = mic::read_bag_records(dir + "/pair.bag", {"/tst/field", "ref/field"}, &warnings);
  EXPECT_TRUE(warnings.empty());
  ASSERT_EQ(back.size(), 2u);
  expect_same_record_to_one_ulp(back[0], pair.test);
  expect_same_record_to_one_ulp(back[1], pair.reference);
  EXPECT_EQ(back[0].header.at("frame_id"), "tst_frame");
  EXPECT_EQ(back[1].source, dir + "/pair.bag:/ref/field");
  std::size_t nan_rows = 0;
  for (Eigen::Index i = 0; i < back[0].values_nT.rows(); ++i) nan_rows += std::isnan(back[0].values_nT(i, 0));
  EXPECT_GT(nan_rows, 0u) << "the simulated gaps travel as NaN messages";

  const mic::BagTemperatureStream t = mic::read_bag_temperatures(dir + "/pair.bag", "/ref/sensor_temperature");
  EXPECT_EQ(t.time_s, temperature.time_s);
  EXPECT_EQ(t.celsius, temperature.celsius);
  EXPECT_EQ(t.frame_id, "ref_frame");
}

TEST(BagRecords, MissingTopicWrongTypeAndUnreadableBagAreNamed) {
  const std::string dir = make_temp_dir("bag_errors");
  mic::VectorRecord r;
  r.time_s = {1747180800.0, 1747180801.0};
  r.values_nT = mic::Readings::Ones(2, 3);
  r.source = "tiny";
  mic::write_records_bag(dir + "/b.bag", {{"/a/field", "a", &r}}, {{"/a/temperature", "a", {1747180800.0}, {20.0}}});
  try {
    mic::read_bag_records(dir + "/b.bag", {"/a/field", "/b/field"});
    ADD_FAILURE();
  } catch (const mic::InputError& e) {
    EXPECT_TRUE(has(e.what(), "/b/field")) << e.what();
    EXPECT_TRUE(has(e.what(), "/a/field (sensor_msgs/MagneticField)")) << e.what();
  }
  try {
    mic::read_bag_records(dir + "/b.bag", {"/a/temperature"});
    ADD_FAILURE();
  } catch (const mic::InputError& e) {
    EXPECT_TRUE(has(e.what(), "holds sensor_msgs/Temperature")) << e.what();
  }
  { std::ofstream(dir + "/not.bag") << "not a bag\n"; }
  EXPECT_THROW(mic::read_bag_records(dir + "/not.bag", {"/a/field"}), mic::InputError);
  mic::VectorRecord early = r;
  early.time_s[0] = -1.0;
  EXPECT_THROW(mic::write_records_bag(dir + "/c.bag", {{"/a/field", "a", &early}}, {}), mic::InputError);
}

TEST(BagRecords, MessagesOutOfStampOrderAreSortedAndRepeatsDropped) {
  const std::string dir = make_temp_dir("bag_order");
  {
    rosbag::Bag bag(dir + "/o.bag", rosbag::bagmode::Write);
    const double stamps[] = {10.0, 12.0, 11.0, 12.0, 13.0};
    for (int i = 0; i < 5; ++i) {
      sensor_msgs::MagneticField m;
      m.header.stamp = ros::Time(stamps[i]);
      m.magnetic_field.x = 1e-9 * i;  // the first of the repeated stamps (i = 1) is kept
      bag.write("/f", ros::Time(100.0 + i), m);  // bag time in arrival order, not stamp order
    }
  }
  std::vector<std::string> warnings;
  const mic::VectorRecord r = mic::read_bag_records(dir + "/o.bag", {"f"}, &warnings).front();
  EXPECT_EQ(r.time_s, (std::vector<double>{10.0, 11.0, 12.0, 13.0}));
  EXPECT_DOUBLE_EQ(r.values_nT(2, 0), 1.0);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_TRUE(has(warnings[0], "1 with a repeated stamp dropped")) << warnings[0];
}

// ---- records_to_bag and calibrate_records --bag -------------------------------------------------

// The real WIC day: IAGA-2002 -> bag -> calibrate_records --bag gives the report of
// calibrate_records on the files (the paper's layout: four intervals and the day).
TEST(RecordsToBag, WicDayBagGivesTheSameCalibrationAsTheFiles) {
  const std::string dir = make_temp_dir("bag_wic");
  const std::string lemi = package_data("wic20250514_lemi036.sec.gz"), fge = package_data("wic20250514_fge.sec.gz");
  ProgramRun r = run_program(RECORDS_TO_BAG_BIN, "--reference " + lemi + " --test " + fge + " -o " + dir +
                                      "/wic.bag --reference-topic /wic/lemi036/magnetic_field --test-topic "
                                      "/wic/fge/magnetic_field --reference-frame lemi036 --test-frame fge");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(has(r.output, "wrote " + dir + "/wic.bag: 172800 messages")) << r.output;
  EXPECT_TRUE(has(r.output, "skipped records: 0 in the reference, 0 in the test")) << r.output;
  const auto records = mic::read_bag_records(dir + "/wic.bag", {"/wic/lemi036/magnetic_field", "/wic/fge/magnetic_field"});
  expect_same_record_to_one_ulp(records[0], mic::read_record(lemi));
  expect_same_record_to_one_ulp(records[1], mic::read_record(fge));
  EXPECT_EQ(records[1].header.at("frame_id"), "fge");
  EXPECT_EQ(mic::bag_topics(dir + "/wic.bag").size(), 2u) << "IAGA-2002 has no temperatures";

  r = run_program(CALIBRATE_RECORDS_BIN, "--bag " + dir + "/wic.bag --reference-topic /wic/lemi036/magnetic_field "
                                 "--test-topic /wic/fge/magnetic_field --intervals 4 --json " + dir + "/bag.json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(has(r.output, "reference: " + dir + "/wic.bag:/wic/lemi036/magnetic_field")) << r.output;
  r = run_program(CALIBRATE_RECORDS_BIN, "--reference " + lemi + " --test " + fge + " --intervals 4 --json " + dir + "/file.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const nlohmann::json bag = read_json(dir + "/bag.json"), file = read_json(dir + "/file.json");
  ASSERT_EQ(bag["windows"].size(), 5u);
  expect_same_report(bag, file, 1e-7);
  EXPECT_EQ(bag["settings"]["test"], dir + "/wic.bag:/wic/fge/magnetic_field");
  // The bag's calibration applies to the instrument's file (H, E, Z): a bag names no components,
  // so export_corrected has none to hold against the file's.
  r = run_program(EXPORT_CORRECTED_BIN, "--test " + fge + " --calibration " + dir + "/bag.json -o " + dir + "/fge.sec");
  ASSERT_EQ(r.status, 0) << r.output;
  // Written: t n^-1 with the bag's whole-record n, to the 0.01 nT of the format.
  Eigen::Matrix3d n;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) n(i, j) = bag["windows"][4]["matrix"][i][j];
  }
  ASSERT_EQ(bag["windows"][4]["label"], "whole record");
  const mic::VectorRecord test = mic::read_record(fge), corrected = mic::read_iaga2002(dir + "/fge.sec");
  ASSERT_EQ(corrected.size(), 86400u);
  const mic::Readings exact = test.values_nT * n.inverse();
  EXPECT_LE((corrected.values_nT - exact).cwiseAbs().maxCoeff(), 0.005 + 1e-9);
  // The bag's report names its topics' frames; from the bag, export_corrected holds the test
  // topic's frame against it: the FGE's topic is corrected, the LEMI-036's refused, both named.
  EXPECT_EQ(bag["preprocessing"]["test_frame_id"], "fge");
  EXPECT_EQ(bag["preprocessing"]["reference_frame_id"], "lemi036");
  r = run_program(EXPORT_CORRECTED_BIN, "--bag " + dir + "/wic.bag --test-topic /wic/fge/magnetic_field --calibration " +
                                            dir + "/bag.json -o " + dir + "/fge_from_bag.sec");
  ASSERT_EQ(r.status, 0) << r.output;
  r = run_program(EXPORT_CORRECTED_BIN, "--bag " + dir + "/wic.bag --test-topic /wic/lemi036/magnetic_field --calibration " +
                                            dir + "/bag.json -o " + dir + "/lemi_from_bag.sec");
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_TRUE(has(r.output, "frame_id 'lemi036', but " + dir + "/bag.json was estimated on a test stream of frame_id 'fge'"))
      << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/lemi_from_bag.sec"));
}

// A simulated 10 Hz LEMI-025 pair: the reference as LemiBin, the test as a raw serial capture
// with two bursts of noise. records_to_bag reports them with their byte offsets, keeps every good
// reading, writes the temperatures; the calibration from the bag is that of the files (through
// read_record's LEMI dispatch), decimation to 1 Hz included.
TEST(RecordsToBag, LemiFormatsWithDamageTemperaturesAndTheSameCalibration) {
  const std::string dir = make_temp_dir("bag_lemi");
  const double t0 = 1747180800.0;
  mic::SimulationSettings s;
  s.start_time_s = t0 - 0.3;
  s.sample_period_s = 0.1;
  s.duration_s = 4 * 3600.0;
  s.keep_clean_field = false;
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  const auto reference_packets = mic::test::lemi_packets_of(pair.reference, t0);
  const auto test_packets = mic::test::lemi_packets_of(pair.test, t0);
  mic::test::write_lemi_bin_file(dir + "/reference.bin", reference_packets);
  mic::test::write_lemi_stream(dir + "/test.raw", test_packets, {100, 5000});
  mic::test::write_lemi_stream(dir + "/test_clean.raw", test_packets);

  ProgramRun r = run_program(RECORDS_TO_BAG_BIN, "--reference " + dir + "/reference.bin --test " + dir + "/test.raw -o " + dir +
                                      "/lemi.bag --progress-delay 0 --reference-topic /lemi/ref/magnetic_field "
                                      "--test-topic /lemi/test/magnetic_field");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(has(r.output, "(LemiBin): 144000 samples")) << r.output;
  EXPECT_TRUE(has(r.output, "(LEMI-025 byte stream): 144000 samples")) << r.output;
  EXPECT_TRUE(has(r.output, dir + "/test.raw byte " + std::to_string(101 * 153) + ": skipped")) << r.output;
  EXPECT_TRUE(has(r.output, dir + "/test.raw byte " + std::to_string(5001 * 153 + 37) + ": skipped")) << r.output;
  EXPECT_TRUE(has(r.output, "skipped records: 0 in the reference, 2 in the test")) << r.output;
  EXPECT_TRUE(has(r.output, "writing " + dir + "/lemi.bag")) << "progress shown: " << r.output;
  EXPECT_TRUE(has(r.output, "/lemi/test/temperature/sensor: 14400")) << r.output;
  EXPECT_TRUE(has(r.output, "/lemi/ref/temperature/electronics: 14400")) << r.output;

  const auto records = mic::read_bag_records(dir + "/lemi.bag", {"/lemi/ref/magnetic_field", "/lemi/test/magnetic_field"});
  expect_same_record_to_one_ulp(records[0], mic::read_record(dir + "/reference.bin"));
  expect_same_record_to_one_ulp(records[1], mic::read_record(dir + "/test_clean.raw"));  // nothing good lost
  const mic::BagTemperatureStream sensor = mic::read_bag_temperatures(dir + "/lemi.bag", "/lemi/test/temperature/sensor");
  ASSERT_EQ(sensor.celsius.size(), 14400u);
  for (std::size_t j = 0; j < 14400; j += 997) {
    EXPECT_DOUBLE_EQ(sensor.time_s[j], t0 + static_cast<double>(j) - 0.3);
    EXPECT_NEAR(sensor.celsius[j], mic::test::lemi_sensor_temperature(j), 1e-9);
  }

  // With the reference's noise from the pair (the default): on the second 2-hour interval the
  // one-ulp tesla round trip once flipped its x fit between white 6.5 pT and 1/f 3.0
  // pT/sqrt(Hz), moving n(z,x) by 6e-5 (the one positive bin of six was fitted alone, by
  // either term exactly), before the fit was made continuous: the two readers agree to 1e-7.
  const std::string common = " --intervals 2 --json ";
  r = run_program(CALIBRATE_RECORDS_BIN, "--bag " + dir + "/lemi.bag --reference-topic /lemi/ref/magnetic_field --test-topic "
                                 "/lemi/test/magnetic_field" + common + dir + "/bag.json");
  ASSERT_EQ(r.status, 0) << r.output;
  r = run_program(CALIBRATE_RECORDS_BIN, "--reference " + dir + "/reference.bin --test " + dir + "/test.raw" + common + dir +
                                     "/file.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const nlohmann::json bag = read_json(dir + "/bag.json");
  EXPECT_TRUE(bag["preprocessing"]["decimated"].get<bool>());
  // The test's sensor temperature reaches the estimate from the bag (its sibling topic) as from
  // the file (the packets), reading for reading: the same temperature terms.
  EXPECT_EQ(bag["preprocessing"]["temperature_channel"], "sensor_temperature");
  expect_same_report(bag, read_json(dir + "/file.json"), 1e-7);
  // And the calibration is the simulated one.
  const nlohmann::json& whole = bag["windows"][2];
  for (int k = 0; k < 9; ++k) {
    EXPECT_LT(std::abs(whole["matrix"][k / 3][k % 3].get<double>() - pair.n_true(k / 3, k % 3)),
              4.0 * whole["matrix_stderr"][k / 3][k % 3].get<double>())
        << k;
  }
}

// Damaged IAGA-2002 lines: the file refused, naming the first line, and no bag written (as
// calibrate_records refuses it); with --skip-damaged named with their line numbers, skipped,
// counted, the rest converted.
TEST(RecordsToBag, DamagedTextRecordsAreRefusedOrNamedSkippedAndCounted) {
  const std::string dir = make_temp_dir("bag_damaged");
  mic::SimulationSettings s;
  s.duration_s = 7200.0;
  s.keep_clean_field = false;
  mic::SimulatedPair pair = mic::simulate_pair(s);
  pair.reference.station = pair.test.station = "SIM";
  mic::write_iaga2002(dir + "/reference.sec", pair.reference);
  mic::write_iaga2002(dir + "/test.sec", pair.test);
  std::vector<std::string> lines = mic::test::read_lines(dir + "/test.sec");
  const std::size_t d = mic::test::iaga_first_data_line(lines);
  lines[d + 10].replace(45, 5, "#####");
  lines[d + 5000].replace(11, 2, "25");  // hour 25
  mic::test::write_lines(dir + "/test_damaged.sec", lines, true);

  const std::string inputs = "--reference " + dir + "/reference.sec --test " + dir + "/test_damaged.sec -o " + dir + "/d.bag";
  const ProgramRun refused = run_program(RECORDS_TO_BAG_BIN, inputs);
  EXPECT_EQ(refused.status, 1) << refused.output;
  EXPECT_TRUE(has(refused.output, "2 damaged line(s), the first " + dir + "/test_damaged.sec:" + std::to_string(d + 11) + ": "))
      << refused.output;
  EXPECT_TRUE(has(refused.output, "--skip-damaged")) << refused.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/d.bag")) << "a bag written from a refused file";
  const ProgramRun calibrate = run_program(CALIBRATE_RECORDS_BIN, "--reference " + dir + "/reference.sec --test " + dir +
                                                                      "/test_damaged.sec");
  EXPECT_EQ(calibrate.status, 1) << "calibrate_records and records_to_bag disagree on a damaged line: "
                                 << calibrate.output;
  EXPECT_TRUE(has(calibrate.output, dir + "/test_damaged.sec:" + std::to_string(d + 11))) << calibrate.output;

  const ProgramRun r = run_program(RECORDS_TO_BAG_BIN, inputs + " --skip-damaged");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(has(r.output, dir + "/test_damaged.sec:" + std::to_string(d + 11) + ": ")) << r.output;
  EXPECT_TRUE(has(r.output, dir + "/test_damaged.sec:" + std::to_string(d + 5001) + ": ")) << r.output;
  EXPECT_TRUE(has(r.output, "skipped records: 0 in the reference, 2 in the test")) << r.output;
  const auto back = mic::read_bag_records(dir + "/d.bag", {"/test/magnetic_field"});
  expect_same_record_to_one_ulp(back[0],
                                mic::test::without_samples(mic::read_iaga2002(dir + "/test.sec"), {10, 5000}));
}

TEST(CalibrateRecordsBag, BadBagRequestsAreNamed) {
  const std::string dir = make_temp_dir("bag_cli");
  mic::VectorRecord r;
  r.time_s = {1747180800.0, 1747180801.0};
  r.values_nT = mic::Readings::Ones(2, 3);
  mic::write_records_bag(dir + "/b.bag", {{"/reference/magnetic_field", "r", &r}}, {});
  ProgramRun run_missing = run_program(CALIBRATE_RECORDS_BIN, "--bag " + dir +
                                                   "/b.bag --reference-topic /reference/magnetic_field --test-topic /nope");
  EXPECT_EQ(run_missing.status, 1);
  EXPECT_TRUE(has(run_missing.output, "no sensor_msgs/MagneticField message on topic /nope")) << run_missing.output;
  ProgramRun both = run_program(CALIBRATE_RECORDS_BIN, "--bag " + dir + "/b.bag --reference x --test y --reference-topic a --test-topic b");
  EXPECT_NE(both.status, 0);
  EXPECT_TRUE(has(both.output, "--reference excludes --bag") || has(both.output, "--bag excludes --reference"))
      << both.output;
  ProgramRun none = run_program(CALIBRATE_RECORDS_BIN, "--intervals 2");
  EXPECT_EQ(none.status, 1);
  EXPECT_TRUE(has(none.output, "--reference: is required (or --bag")) << none.output;
  ProgramRun no_topic = run_program(CALIBRATE_RECORDS_BIN, "--bag " + dir + "/b.bag --test-topic a");
  EXPECT_NE(no_topic.status, 0);
  EXPECT_TRUE(has(no_topic.output, "--reference-topic")) << no_topic.output;
}

TEST(CalibrateRecordsBag, TemperatureUnderTheEarlierTopicNameIsStillRead) {
  // records_to_bag now writes <ns>/temperature/sensor, as the driver publishes it; a bag written
  // before has <ns>/sensor_temperature, and calibrate_records --bag still takes it as the test's
  // sensor temperature (and without any, the window has none).
  const std::string dir = make_temp_dir("bag_old_temperature");
  mic::SimulationSettings s;
  s.duration_s = 6 * 3600.0;
  s.start_time_s = 1747180800.0;
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::BagTemperatureStream temperature{"/test/sensor_temperature", "t", {}, {}};
  for (double t : pair.test.time_s) {
    temperature.time_s.push_back(t);
    temperature.celsius.push_back(20.0 + 0.5 * std::sin(t / 3600.0));
  }
  const std::vector<mic::BagFieldStream> fields = {{"/reference/magnetic_field", "r", &pair.reference},
                                                   {"/test/magnetic_field", "t", &pair.test}};
  mic::write_records_bag(dir + "/old.bag", fields, {temperature});
  mic::write_records_bag(dir + "/none.bag", fields, {});
  for (const std::string name : {"old", "none"}) {
    SCOPED_TRACE(name);
    const ProgramRun r = run_program(CALIBRATE_RECORDS_BIN, "--bag " + dir + "/" + name + ".bag --reference-topic "
                                     "/reference/magnetic_field --test-topic /test/magnetic_field --json " + dir + "/" +
                                     name + ".json");
    ASSERT_EQ(r.status, 0) << r.output;
    const nlohmann::json report = read_json(dir + "/" + name + ".json");
    if (name == "old") {
      EXPECT_EQ(report["preprocessing"]["temperature_channel"], "sensor_temperature") << report["preprocessing"];
      // The values themselves arrived: the window's temperature range is the written series'.
      const auto [low, high] = std::minmax_element(temperature.celsius.begin(), temperature.celsius.end());
      const nlohmann::json& w = report["windows"].back();
      ASSERT_TRUE(w["temperature_fitted"].get<bool>()) << w["temperature_text"];
      EXPECT_NEAR(w["temperature_range_C"].get<double>(), *high - *low, 0.01) << w["temperature_text"];
    } else {
      EXPECT_TRUE(report["preprocessing"]["temperature_channel"].is_null() ||
                  report["preprocessing"]["temperature_channel"] == "")
          << report["preprocessing"];
    }
  }
}

// ---- export_corrected from a bag, with calibration_node's YAML ----------------------------------

// MagPy CDF in, several files per instrument: the LEMI-036 day as two overlapping ImagCDF files
// (given in reverse order) makes the bag of the single MagPy CDF file, temperatures included.
TEST(RecordsToBag, CdfDaySplitIntoTwoFilesGivesTheSingleFileBag) {
  const std::string dir = make_temp_dir("bag_cdf");
  const std::string lemi = mic::test::test_data("cdf/LEMI036_1_0002_0002_2025-05-14.cdf");
  const std::string fge = mic::test::test_data("cdf/FGE_S0252_0002_0002_2025-05-14.cdf");
  const mic::VectorRecord day = mic::read_record(lemi);
  for (const auto& [name, first, last] : {std::tuple<const char*, long, long>{"/a.cdf", 0, 50000}, {"/b.cdf", 43200, 86400}}) {
    mic::VectorRecord part = day;
    part.time_s.assign(day.time_s.begin() + first, day.time_s.begin() + last);
    part.values_nT = day.values_nT.middleRows(first, last - first);
    for (mic::AuxiliaryChannel& a : part.auxiliary) a.values.assign(a.values.begin() + first, a.values.begin() + last);
    mic::write_imagcdf(dir + name, part);
  }
  ProgramRun r = run_program(RECORDS_TO_BAG_BIN, "--quiet --reference " + dir + "/b.cdf " + dir + "/a.cdf --test " + fge +
                                                     " -o " + dir + "/split.bag");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(has(r.output, dir + "/b.cdf: 6800 samples from 2025-05-14T12:00:00.000Z")) << r.output;
  EXPECT_TRUE(has(r.output, "reference: 2 files joined: 86400 samples")) << r.output;
  const auto records = mic::read_bag_records(dir + "/split.bag", {"/reference/magnetic_field", "/test/magnetic_field"});
  expect_same_record_to_one_ulp(records[0], day);
  expect_same_record_to_one_ulp(records[1], mic::read_record(fge));
  const mic::BagTemperatureStream t = mic::read_bag_temperatures(dir + "/split.bag", "/reference/temperature/sensor");
  EXPECT_EQ(t.time_s, day.time_s);
  EXPECT_EQ(t.celsius, day.auxiliary[0].values);
}
