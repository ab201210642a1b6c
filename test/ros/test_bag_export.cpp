// export_corrected from a bag with calibration_node's YAML file, without a master (the
// executable test_bag_records; this file is compiled with test_bag_records.cpp as one
// translation unit, so its helpers have names of their own).
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "bag_records.hpp"  // src/program_support
#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <string>

namespace mic = magnetometer_insitu_calibration;  // as in test_bag_records.cpp: the same alias

namespace {

bool export_output_has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace

TEST(ExportCorrectedBag, YamlCalibrationFromTheLiveNodeAndTheTestFromABag) {
  using mic::test::make_temp_dir;
  using mic::test::ProgramRun;
  using mic::test::run_program;
  const auto has = export_output_has;
  const std::string dir = make_temp_dir("bag_export");
  mic::SimulationSettings s;
  s.duration_s = 3600.0;
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::write_records_bag(dir + "/p.bag", {{"/test/magnetic_field", "fge", &pair.test}}, {});
  mic::MagnetometerCalibration c;
  c.test_name = "fge";
  c.reference_frame_id = "lemi";
  c.test_frame_id = "fge";
  c.window_start = ros::Time(1747180800.0);
  c.window_end = ros::Time(1747184399.0);
  for (int k = 0; k < 9; ++k) c.matrix[k] = pair.n_true(k / 3, k % 3);
  c.scale_ratio = {0.9996, 1.0004, 1.0004};
  c.covariance_cells = std::numeric_limits<double>::infinity();  // no covariance: taken as known
  c.interval_quantile = mic::kNormalQuantile95;
  c.quality = mic::MagnetometerCalibration::QUALITY_OK;
  c.quality_text = "ok";
  c.accepted = true;
  { std::ofstream(dir + "/fge.yaml") << mic::calibration_to_yaml(c, "/calibration_fge"); }
  const ProgramRun r = run_program(EXPORT_CORRECTED_BIN, "--bag " + dir + "/p.bag --test-topic /test/magnetic_field --calibration " +
                                              dir + "/fge.yaml --iaga-code SIM -o " + dir + "/corrected.sec");
  ASSERT_EQ(r.status, 0) << r.output;
  const mic::VectorRecord out = mic::read_iaga2002(dir + "/corrected.sec");
  ASSERT_EQ(out.size(), 3600u);
  EXPECT_EQ(out.time_s, pair.test.time_s);
  // The clean field, within the test noise and the 0.01 nT of the format.
  const mic::Readings e = out.values_nT - pair.field_nT;
  for (int comp = 0; comp < 3; ++comp) {
    EXPECT_LT(std::abs(e.col(comp).mean()), 0.02) << comp;
    EXPECT_LT(e.col(comp).cwiseAbs().maxCoeff(), 0.2) << comp;
  }
  EXPECT_TRUE(has(out.header.at("comments"), "'fge' live window (2025-05-14T00:00:00.000Z to")) << out.header.at("comments");
  EXPECT_TRUE(has(out.header.at("comments"), "p.bag:/test/magnetic_field")) << out.header.at("comments");
}

