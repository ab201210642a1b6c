// Known-truth test of the three-cornered hat: three instruments of different white noise
// (independent, set by the test) recording one simulated field; each instrument's noise PSD,
// 2 sigma^2 dt for white noise of rms sigma per sample, must come back from the pairwise
// residuals alone.
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/estimation/frequency_bins.hpp"
#include "magnetometer_insitu_calibration/estimation/three_cornered_hat.hpp"
#include "magnetometer_insitu_calibration/simulation/co_located_instrument.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

namespace mic = magnetometer_insitu_calibration;

namespace {

/// clean plus independent white noise of rms nT per sample on each axis, drawn from rng.
mic::Readings with_white_noise(const mic::Readings& clean, double rms, std::mt19937_64& rng,
                               std::normal_distribution<double>& normal) {
  mic::Readings r = clean;
  for (Eigen::Index i = 0; i < r.rows(); ++i)
    for (int k = 0; k < 3; ++k) r(i, k) += rms * normal(rng);
  return r;
}

}  // namespace

TEST(ThreeCorneredHat, RecoversEachInstrumentsNoiseLevel) {
  mic::SimulationSettings s;
  s.duration_s = 5 * 86400.0;
  s.variation_rms_nT = 100.0;  // in-band signal >> noise: Eq. 2 of each pair is not attenuated
  s.reference_white_nT = s.test_white_nT = 0.0;
  s.reference_pink_nT_per_sqrt_hz = s.test_pink_nT_per_sqrt_hz = 0.0;
  s.keep_clean_field = true;
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  const mic::Readings& field = pair.field_nT;
  const Eigen::Matrix3d n_b = pair.n_true;
  const Eigen::Matrix3d n_c = mic::co_located_instrument_matrix();
  const double sigma[3] = {0.03, 0.05, 0.08};  // nT rms per sample, white
  std::mt19937_64 rng(12345);
  std::normal_distribution<double> normal;
  auto noisy = [&](const mic::Readings& clean, double rms) { return with_white_noise(clean, rms, rng, normal); };
  const mic::Readings a = noisy(field, sigma[0]), b = noisy(field * n_b, sigma[1]), c = noisy(field * n_c, sigma[2]);
  mic::ThreeCorneredHatSettings hs;
  hs.bins = 1;
  const mic::ThreeCorneredHatResult r = mic::three_cornered_hat(a, b, c, 1.0, hs);
  for (int inst = 0; inst < 3; ++inst) {
    const double truth = 2.0 * sigma[inst] * sigma[inst] * 1.0;  // one-sided white PSD, nT^2/Hz
    for (int k = 0; k < 3; ++k) {
      // Noise level (ASD, sqrt of the PSD) within 20 %.
      EXPECT_NEAR(std::sqrt(r.psd_nT2_per_hz[inst][0](k) / truth), 1.0, 0.2) << "instrument " << inst << " axis " << k;
    }
  }
}

TEST(ThreeCorneredHat, StatesTheScatterOfItsEstimates) {
  // The default method's per-bin standard deviations against the estimates' own scatter about
  // the truth: 20 one-day records (the simulator's quiet field, 4 bins over the band), three
  // instruments of white noise 0.1 / 0.01 / 0.05 nT (a noisy reference, as the hat is used),
  // 240 values per instrument. All three are held to their stated deviation, the quiet one too:
  // its estimates scatter about its small truth by about the other two's noise, sqrt(N_b N_c / 2
  // / harmonics), not by its own (a formula stating zero wherever its estimate
  // came out negative put the noisy two at 1.15-1.17).
  const double sigma[3] = {0.1, 0.01, 0.05};
  double z2[3] = {0.0, 0.0, 0.0};
  int values = 0;
  for (std::uint64_t seed = 500; seed < 520; ++seed) {
    mic::SimulationSettings s;
    s.seed = seed;
    s.reference_white_nT = s.test_white_nT = 0.0;
    s.reference_pink_nT_per_sqrt_hz = s.test_pink_nT_per_sqrt_hz = 0.0;
    s.keep_clean_field = true;
    const mic::SimulatedPair pair = mic::simulate_pair(s);
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> normal;
    auto noisy = [&](const mic::Readings& clean, double rms) { return with_white_noise(clean, rms, rng, normal); };
    const mic::Readings a = noisy(pair.field_nT, sigma[0]), b = noisy(pair.field_nT * pair.n_true, sigma[1]),
                        c = noisy(pair.field_nT * mic::co_located_instrument_matrix(), sigma[2]);
    const mic::ThreeCorneredHatResult r = mic::three_cornered_hat(a, b, c, 1.0);
    for (int inst = 0; inst < 3; ++inst) {
      ASSERT_EQ(r.psd_sd_nT2_per_hz[static_cast<std::size_t>(inst)].size(), 4u);
      for (std::size_t k = 0; k < 4; ++k) {
        const Eigen::Vector3d z = (r.psd_nT2_per_hz[static_cast<std::size_t>(inst)][k].array() -
                                   2.0 * sigma[inst] * sigma[inst]) / r.psd_sd_nT2_per_hz[static_cast<std::size_t>(inst)][k].array();
        z2[inst] += z.squaredNorm();
        EXPECT_TRUE((r.psd_sd_nT2_per_hz[static_cast<std::size_t>(inst)][k].array() > 0.0).all());
      }
    }
    values += 12;
  }
  for (int inst : {0, 1, 2}) {
    const double rms = std::sqrt(z2[inst] / values);
    std::printf("instrument %d: rms (estimate - truth) / stated sd over %d values: %.3f\n", inst, values, rms);
    EXPECT_GT(rms, 0.8) << inst;
    EXPECT_LT(rms, 1.3) << inst;
  }
}

TEST(ThreeCorneredHat, BadInputIsNamed) {
  const mic::Readings a = mic::Readings::Zero(100, 3), b = mic::Readings::Zero(90, 3);
  EXPECT_THROW(mic::three_cornered_hat(a, b, a, 1.0), mic::InputError);
  mic::ThreeCorneredHatSettings hs;
  hs.bins = 0;
  EXPECT_THROW(mic::three_cornered_hat(a, a, a, 1.0, hs), mic::InputError);
  // Explicit edges that do not ascend (or one edge only) are refused, naming the hat.
  for (const std::vector<double>& edges : {std::vector<double>{0.01, 0.001}, std::vector<double>{0.01},
                                           std::vector<double>{0.0, 0.01}}) {
    mic::ThreeCorneredHatSettings bad;
    bad.bin_edges_hz = edges;
    try {
      mic::three_cornered_hat(a, a, a, 1.0, bad);
      ADD_FAILURE() << "edges accepted";
    } catch (const mic::InputError& e) {
      EXPECT_EQ(e.where(), "three_cornered_hat") << e.what();
    }
  }
}

TEST(LogSpacedBinEdges, AreTheBandsEndsAndEqualRatiosBetween) {
  // Worked by hand: 0.001-0.1 Hz in 2 bins is 0.001, 0.01, 0.1 Hz; the top edge is the band's
  // own value, not a rounded power.
  const std::vector<double> two = mic::log_spaced_bin_edges(0.001, 0.1, 2);
  ASSERT_EQ(two.size(), 3u);
  EXPECT_DOUBLE_EQ(two[0], 0.001);
  EXPECT_NEAR(two[1], 0.01, 1e-15);
  EXPECT_EQ(two[2], 0.1);
  const std::vector<double> six = mic::log_spaced_bin_edges(0.01, 0.25, 6);
  ASSERT_EQ(six.size(), 7u);
  for (std::size_t k = 1; k + 1 < six.size(); ++k) EXPECT_NEAR(six[k] / six[k - 1], std::pow(25.0, 1.0 / 6.0), 1e-12);
  EXPECT_EQ(six.back(), 0.25);
}
