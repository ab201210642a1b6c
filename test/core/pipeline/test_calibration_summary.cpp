// The summary's sentence on a window whose remote reference found the pair alone biased.
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_summary.hpp"

#include <gtest/gtest.h>

#include <string>

// The pair (reference and test, side by side) sees a local disturbance that the remote
// observatory does not: that biases the pair's own estimate, and n rests on the remote. The
// summary says which instrument sees the disturbance.
TEST(CalibrationSummary, ABiasedPairIsSaidToSeeTheDisturbanceTheRemoteDoesNot) {
  namespace mic = magnetometer_insitu_calibration;
  mic::PairCalibration calibration;
  mic::CalibrationWindow window;
  window.label = mic::kWholeRecordLabel;
  window.estimate.remote.used = true;
  window.estimate.remote.pair_biased = true;
  calibration.windows.push_back(window);
  const std::string summary = mic::format_calibration_summary(calibration, mic::Tolerances());
  EXPECT_NE(summary.find("The pair alone would have been biased (the pair sees a local disturbance the remote does "
                         "not); n rests on the remote."),
            std::string::npos)
      << summary;
  EXPECT_EQ(summary.find("the remote sees a local disturbance"), std::string::npos) << summary;
}
