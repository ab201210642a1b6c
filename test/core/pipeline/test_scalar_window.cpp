// The scalar check (estimation/scalar_check.hpp, pipeline/scalar_window.hpp) against known truth:
// a simulated quiet day whose reference reads 0.3 % high, with an absolute scalar magnetometer
// every 1 s or every 30 s (its stamps 0.37 s off whole seconds, and true); and the scalar
// records' reading.
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/scalar_record.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_summary.hpp"
#include "magnetometer_insitu_calibration/simulation/scalar_magnetometer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

namespace mic = magnetometer_insitu_calibration;

namespace {

struct Day {
  mic::SimulatedPair pair;
  mic::ScalarRecord scalar;
};

Day day(std::uint64_t seed, double scalar_period_s, double reference_scale) {
  mic::SimulationSettings s;
  s.seed = seed;
  s.keep_clean_field = true;
  Day d{mic::simulate_pair(s), {}};
  mic::ScalarMagnetometerSettings sm;
  sm.seed = seed + 500;
  sm.period_s = scalar_period_s;
  d.scalar = mic::simulate_scalar_magnetometer(d.pair, sm);
  d.pair.reference.values_nT *= reference_scale;
  return d;
}

}  // namespace

TEST(ScalarCheck, RecoversTheReferencesScaleAlongTheFieldFromA1sAndA30sScalar) {
  for (const double period : {1.0, 30.0}) {
    const Day d = day(61, period, 1.003);
    mic::CalibrationSettings settings;
    const mic::PairCalibration c = mic::calibrate_records(d.pair.reference, d.pair.test, settings, {nullptr, nullptr, &d.scalar});
    const mic::ScalarCheck& s = c.windows.back().scalar;
    ASSERT_TRUE(s.assessed) << s.text;
    const double se = s.reference_scale_ci95 / 1.96;
    std::printf("scalar every %g s: reference scale %.5f +- %.5f (truth 1.003), delay %.2f s; %s\n", period,
                s.reference_scale, s.reference_scale_ci95, s.delay_s, s.text.c_str());
    EXPECT_LT(std::abs(s.reference_scale - 1.003) / se, 4.0) << period;
    EXPECT_LT(s.reference_scale_ci95, 0.006) << "narrow enough to tell a 0.3 % error from none";
    // The field's direction: the main field's (the simulator's 21500, 500, 43000 nT).
    const Eigen::Vector3d b = Eigen::Vector3d(21500.0, 500.0, 43000.0).normalized();
    EXPECT_LT((s.direction_cosines - b).cwiseAbs().maxCoeff(), 0.01) << s.direction_cosines.transpose();
    // Its stamps are off whole seconds but true: put on the grid, F shows no delay.
    EXPECT_LT(std::abs(s.delay_s), 0.1) << period;
    EXPECT_NE(s.text.find(period == 1.0 ? "window's 1 s grid" : "scalar's own 30 s grid"), std::string::npos) << s.text;
    // The summary an engineer reads first says what the scalar found of the reference.
    const std::string summary = mic::format_calibration_summary(c, settings.window.tolerances);
    EXPECT_NE(summary.find("Against the scalar magnetometer: " + s.text), std::string::npos) << summary;
  }
}

// Windows that start between a 30 s scalar's samples (here at :15 and :45 of each minute): the
// fit's grid starts at the scalar's first sample in the window, so that F stays on its own
// samples; a grid from the window's start put F half-way between them by a straight line, which
// took a third of its amplitude at 0.01 Hz, and the windows read scales several half-widths high.
TEST(ScalarCheck, A30sScalarInWindowsThatStartBetweenItsSamples) {
  mic::SimulationSettings s;
  s.seed = 64;
  s.keep_clean_field = true;
  mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::ScalarMagnetometerSettings sm;
  sm.seed = 564;
  sm.period_s = 30.0;
  sm.offset_s = 15.0;
  const mic::ScalarRecord scalar = mic::simulate_scalar_magnetometer(pair, sm);
  pair.reference.values_nT *= 1.003;
  mic::CalibrationSettings settings;
  settings.windows.window_s = 6 * 3600.0;
  settings.windows.step_s = 6 * 3600.0;
  const mic::PairCalibration c = mic::calibrate_records(pair.reference, pair.test, settings, {nullptr, nullptr, &scalar});
  ASSERT_GE(c.windows.size(), 4u);
  for (const auto& w : c.windows) {
    ASSERT_TRUE(w.scalar.assessed) << w.label << ": " << w.scalar.text;
    std::printf("%s: reference scale %.5f +- %.5f\n", w.label.c_str(), w.scalar.reference_scale, w.scalar.reference_scale_ci95);
    EXPECT_LT(std::abs(w.scalar.reference_scale - 1.003), 1.5 * w.scalar.reference_scale_ci95) << w.label;
  }
}

TEST(ScalarCheck, ARightReferenceIsNotFlagged) {
  const Day d = day(62, 1.0, 1.0);
  const mic::PairCalibration c = mic::calibrate_records(d.pair.reference, d.pair.test, {}, {nullptr, nullptr, &d.scalar});
  const mic::ScalarCheck& s = c.windows.back().scalar;
  ASSERT_TRUE(s.assessed) << s.text;
  EXPECT_LT(std::abs(s.reference_scale - 1.0), 2.5 * s.reference_scale_ci95 / 1.96);
}

// A 10 Hz pair decimated to 1 s, band up to 0.05 Hz where the decimation's low-pass takes 4.5 %
// of the pair's gain: F (1 s, 0.37 s off the seconds) goes through the same filter onto the
// pair's epochs, or the reference's scale along the field reads low (these windows: 0.9960-0.9964
// before, 1.0006-1.0016 after; the simulated station's 15-minute windows 0.9935 +- 0.008 before).
// Three hourly windows.
TEST(ScalarCheck, ADecimatedPairsLowPassIsNotReadAsTheReferencesScale) {
  mic::SimulationSettings s;
  s.seed = 63;
  s.duration_s = 3 * 3600.0 + 60.0;  // the decimation's kernel takes a few seconds at each end
  s.sample_period_s = 0.1;
  s.keep_clean_field = true;
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::ScalarMagnetometerSettings sm;
  sm.seed = 563;
  const mic::ScalarRecord scalar = mic::simulate_scalar_magnetometer(pair, sm);
  mic::CalibrationSettings settings;
  settings.windows.window_s = 3600.0;
  settings.windows.step_s = 3600.0;
  settings.window.estimator.band_low_hz = 0.002;
  settings.window.estimator.band_high_hz = 0.05;
  const mic::PairCalibration c = mic::calibrate_records(pair.reference, pair.test, settings, {nullptr, nullptr, &scalar});
  ASSERT_TRUE(c.report.decimated());
  ASSERT_GE(c.windows.size(), 3u);
  double mean = 0.0;
  for (const auto& w : c.windows) {
    ASSERT_TRUE(w.scalar.assessed) << w.scalar.text;
    std::printf("window: reference scale %.5f +- %.5f\n", w.scalar.reference_scale, w.scalar.reference_scale_ci95);
    EXPECT_LT(std::abs(w.scalar.reference_scale - 1.0), 1.5 * w.scalar.reference_scale_ci95) << w.scalar.text;
    mean += w.scalar.reference_scale / static_cast<double>(c.windows.size());
  }
  EXPECT_GT(mean, 0.997) << "the windows' mean scale: the pair's low-pass read as the reference's";
}

TEST(ScalarRecord, ReadsACsvAndNamesABadLine) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "mic_scalar_csv";
  std::filesystem::create_directories(dir);
  const std::string good = (dir / "f.csv").string(), bad = (dir / "bad.csv").string();
  std::ofstream(good) << "time,F\n2025-05-14T00:00:00.370Z,48085.5\n2025-05-14T00:00:30.370Z,99999\n1747180860.37,48085.4\n";
  const mic::ScalarRecord r = mic::read_scalar_record(good);
  ASSERT_EQ(r.size(), 3u);
  EXPECT_NEAR(r.time_s[0], 1747180800.37, 1e-6);
  EXPECT_TRUE(std::isnan(r.value_nT[1])) << "the IAGA sentinel is missing";
  EXPECT_DOUBLE_EQ(r.value_nT[2], 48085.4);
  std::ofstream(bad) << "time,F\n2025-05-14T00:00:00Z,48085.5\n2025-05-14T00:00:01Z,oops\n";
  try {
    mic::read_scalar_record(bad);
    ADD_FAILURE() << "a bad value was read";
  } catch (const mic::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.csv:3"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}
