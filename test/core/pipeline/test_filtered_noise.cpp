// The reference's noise identified above the band on records the Gaussian FIR brought onto the
// estimation epochs (pipeline/reference_noise.hpp, `filter`): a 10 Hz LEMI-025 pair decimated to
// 1 s. The filter's power gain falls across the bins above the band (0.1 at 0.25 Hz), so a fit of
// the filtered bins takes white noise for 1/f; each bin divided by the gain gives back the white
// level the band sees.
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/pipeline/reference_noise.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include "ten_hz_station.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace mic = magnetometer_insitu_calibration;

TEST(FilteredNoise, TheMeanPowerGainIsTheGaussiansOverTheBin) {
  mic::DecimationSettings filter;  // 1 s epochs: sigma 0.966 s
  const double sigma = filter.effective_sigma_s();
  const auto gain2 = [sigma](double f) { return std::exp(-4.0 * M_PI * M_PI * sigma * sigma * f * f); };
  EXPECT_NEAR(mic::mean_power_gain(filter, 0.2499, 0.2501), gain2(0.25), 1e-6);  // 0.100
  EXPECT_NEAR(gain2(0.25), 0.100, 0.001);
  // Over a wide bin, the mean of the gain, not the gain at its middle.
  double mean = 0.0;
  for (int k = 0; k < 10000; ++k) mean += gain2(0.1 + 0.15 * (k + 0.5) / 10000.0) / 10000.0;
  EXPECT_NEAR(mic::mean_power_gain(filter, 0.1, 0.25), mean, 1e-4);
  EXPECT_GT(mic::mean_power_gain(filter, 0.0001, 0.01), 0.998);
}

TEST(FilteredNoise, APairAtTenHertzGivesTheReferencesWhiteNoiseNotOneOverF) {
  // The reference 10x noisier than the test, white only: 0.1 nT rms per 10 Hz sample is
  // 0.1 / sqrt(10) = 31.6 pT rms per 1 s epoch in the band.
  mic::SimulationSettings s = mic::test::ten_hz_station(61, 12.0);
  s.reference_white_nT = 0.1;
  s.test_white_nT = 0.01;
  s.reference_pink_nT_per_sqrt_hz = 0.0;
  s.test_pink_nT_per_sqrt_hz = 0.0;
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  const mic::PairCalibration c = mic::calibrate_records(pair.reference, pair.test, mic::CalibrationSettings{});
  ASSERT_EQ(c.report.alignment, mic::EpochAlignment::kPairedThenDecimated);
  ASSERT_EQ(c.windows.size(), 1u);
  const mic::IdentifiedNoise& noise = c.windows[0].reference_noise;
  ASSERT_TRUE(noise.identified) << noise.text;
  const double truth_nT = 0.1 / std::sqrt(10.0);
  // The white level within 10 % on every axis (1 s records of the same in-band noise: 27-33 pT
  // over seeds 61-66; here 29.7-31.9). A 1/f level may come with it, as on 1 s records: the fit's
  // own scatter (0-9 pT/sqrt(Hz) at both rates on those seeds).
  for (int axis = 0; axis < 3; ++axis) EXPECT_NEAR(noise.white_nT(axis), truth_nT, 0.1 * truth_nT) << noise.text;
  // Without the filter's gain undone (as before), the same window's bins give a white level far
  // under the truth on every axis, the rest read as 1/f.
  const mic::PreparedPair prepared = mic::prepare_pair(pair.reference, pair.test, mic::PreprocessSettings{});
  const mic::WindowRecords w = mic::window_records(prepared, 0, prepared.paired.size(), 60.0);
  const mic::IdentifiedNoise unfiltered = mic::identify_reference_noise_from_pair(
      w.paired.reference_nT, w.paired.test_nT, w.period_s, c.windows[0].estimate, c.windows[0].response_model,
      mic::CalibrationSettings{}.window.estimator.band_high_hz, nullptr);
  ASSERT_TRUE(unfiltered.identified) << unfiltered.text;
  EXPECT_LT(unfiltered.white_nT.maxCoeff(), 0.6 * truth_nT) << unfiltered.text;
  EXPECT_GT(unfiltered.pink_nT_per_sqrt_hz.maxCoeff(), noise.pink_nT_per_sqrt_hz.maxCoeff()) << unfiltered.text;
}
