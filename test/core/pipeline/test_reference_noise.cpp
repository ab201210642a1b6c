// The reference's noise identified from a third instrument (pipeline/reference_noise.hpp): the
// white + 1/f fit against PSDs computed by hand, and the whole path on three simulated
// instruments of known, different noise.
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/pipeline/reference_noise.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "magnetometer_insitu_calibration/simulation/co_located_instrument.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "magnetometer_insitu_calibration/simulation/unmodelled_disturbances.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <limits>
#include <random>

namespace mic = magnetometer_insitu_calibration;

namespace {

/// Bins of the default band in 4 log-spaced steps, and S = 2 w^2 dt + p^2 mean(1/f) per bin.
struct Bins {
  std::vector<double> low{0.0002, 0.0002 * std::pow(50.0, 0.25), 0.0002 * std::pow(50.0, 0.5),
                          0.0002 * std::pow(50.0, 0.75)};
  std::vector<double> high{0.0002 * std::pow(50.0, 0.25), 0.0002 * std::pow(50.0, 0.5),
                           0.0002 * std::pow(50.0, 0.75), 0.01};
  std::vector<Eigen::Vector3d> psd(const Eigen::Vector3d& w, const Eigen::Vector3d& p, double dt) const {
    std::vector<Eigen::Vector3d> out;
    for (std::size_t k = 0; k < low.size(); ++k) {
      const double inverse_f = std::log(high[k] / low[k]) / (high[k] - low[k]);
      out.push_back(2.0 * dt * w.cwiseAbs2() + inverse_f * p.cwiseAbs2());
    }
    return out;
  }
};

}  // namespace

TEST(FitWhiteAndPink, RecoversLevelsFromExactBins) {
  const Bins b;
  const Eigen::Vector3d w(0.01, 0.03, 0.0), p(0.005, 0.0, 0.02);  // nT, nT/sqrt(Hz) at 1 Hz
  Eigen::Vector3d white, pink;
  ASSERT_TRUE(mic::fit_white_and_pink(b.psd(w, p, 1.0), b.low, b.high, 1.0, white, pink));
  for (int c = 0; c < 3; ++c) {  // the squares (PSD terms, nT^2): the square root of a rounding error is 1e-9
    EXPECT_NEAR(white(c) * white(c), w(c) * w(c), 1e-15) << c;
    EXPECT_NEAR(pink(c) * pink(c), p(c) * p(c), 1e-15) << c;
  }
}

TEST(FitWhiteAndPink, TakesNegativeBinsAndReportsAnAxisWhoseBinsSupportNoLevel) {
  const Bins b;
  std::vector<Eigen::Vector3d> psd = b.psd(Eigen::Vector3d::Constant(0.02), Eigen::Vector3d::Constant(0.004), 1.0);
  for (auto& bin : psd) bin(2) = -1e-4;      // z: every bin negative, no level
  psd[1](1) = std::numeric_limits<double>::quiet_NaN();  // y: one bin missing, left out
  Eigen::Vector3d white, pink;
  EXPECT_FALSE(mic::fit_white_and_pink(psd, b.low, b.high, 1.0, white, pink));
  EXPECT_NEAR(white(0), 0.02, 1e-9);
  EXPECT_NEAR(pink(0), 0.004, 1e-9);
  EXPECT_NEAR(white(1), 0.02, 1e-9);
  EXPECT_NEAR(pink(1), 0.004, 1e-9);
  EXPECT_EQ(white(2), 0.0);
  EXPECT_EQ(pink(2), 0.0);
}

TEST(FitWhiteAndPink, LevelsAreContinuousWhereABinCrossesZero) {
  // The pair's estimate of a quiet reference over 2 hours (as in test_bag_records): six
  // bins of 0.03-0.25 Hz, five of them negative on x, the sixth barely positive. The levels
  // once jumped between white 6.5 pT and 1/f 3.0 pT/sqrt(Hz) when one ulp of the records moved
  // (the one positive bin was fitted alone, by either term exactly, and the choice fell to
  // rounding), and a bin crossing zero left or entered the fit. Now a bin moved across zero by
  // 1e-12 of the bins' scale moves the levels by as little.
  std::vector<double> low, high;
  for (int k = 0; k < 6; ++k) {
    low.push_back(0.03 * std::pow(0.25 / 0.03, k / 6.0));
    high.push_back(0.03 * std::pow(0.25 / 0.03, (k + 1) / 6.0));
  }
  const double measured_x[6] = {-1.328068e-04, -8.095010e-05, -6.625215e-05, 8.535001e-05, -9.225458e-05,
                                -1.248744e-05};
  const double measured_y[6] = {3.038684e-03, -7.440820e-04, 7.008330e-04, -3.710773e-04, 1.831483e-04, 5.684265e-06};
  std::vector<Eigen::Vector3d> psd;
  for (int k = 0; k < 6; ++k) psd.emplace_back(measured_x[k], measured_y[k], 2.0e-4 * (k % 2 == 0 ? 1.0 : 1e-13));
  Eigen::Vector3d white, pink;
  mic::fit_white_and_pink(psd, low, high, 1.0, white, pink);
  // x: five of six bins negative and their mean too: no level.
  EXPECT_EQ(white(0), 0.0);
  EXPECT_EQ(pink(0), 0.0);
  for (int c = 1; c < 3; ++c) {
    for (int k = 0; k < 6; ++k) {
      for (const double step : {-1e-12, 1e-12}) {
        std::vector<Eigen::Vector3d> moved = psd;
        moved[static_cast<std::size_t>(k)](c) = (c == 2 && k % 2 == 1) ? step * 2.0e-4 : moved[static_cast<std::size_t>(k)](c) * (1.0 + step);
        Eigen::Vector3d w2, p2;
        mic::fit_white_and_pink(moved, low, high, 1.0, w2, p2);
        EXPECT_NEAR(w2(c) * w2(c), white(c) * white(c), 1e-9 * (white(c) * white(c) + pink(c) * pink(c))) << c << " " << k;
        EXPECT_NEAR(p2(c) * p2(c), pink(c) * pink(c), 1e-9 * (white(c) * white(c) + pink(c) * pink(c))) << c << " " << k;
      }
    }
  }
  // z: alternate bins at 2e-4 nT^2/Hz and at zero (2e-16 either side): a level between.
  EXPECT_GT(white(2) + pink(2), 0.0);
}

TEST(FitWhiteAndPink, IsUnbiasedWhereTheNoiseIsSmallAgainstTheBinsScatter) {
  // A weak noise whose bins' scatter is larger than their value, so that many come out
  // negative: leaving those out biased the fitted PSD up; taking every bin, its mean over 2000
  // draws is the truth within 4 standard errors of that mean.
  std::vector<double> low, high;
  for (int k = 0; k < 6; ++k) {
    low.push_back(0.03 * std::pow(0.25 / 0.03, k / 6.0));
    high.push_back(0.03 * std::pow(0.25 / 0.03, (k + 1) / 6.0));
  }
  const double truth = 2.0 * 0.003 * 0.003;  // white 3 pT at 1 s, nT^2/Hz
  std::mt19937_64 rng(12);
  std::normal_distribution<double> normal(0.0, 1.0);
  double sum = 0.0, sum2 = 0.0;
  int negative = 0;
  const int draws = 2000;
  for (int d = 0; d < draws; ++d) {
    std::vector<Eigen::Vector3d> psd;
    for (int k = 0; k < 6; ++k) {
      psd.push_back(Eigen::Vector3d::Constant(truth + 2.0 * truth * normal(rng)));
      negative += psd.back()(0) < 0.0 ? 1 : 0;
    }
    Eigen::Vector3d white, pink;
    mic::fit_white_and_pink(psd, low, high, 1.0, white, pink);
    const double fitted = 2.0 * white(0) * white(0) + pink(0) * pink(0) * std::log(high[3] / low[3]) / (high[3] - low[3]);
    sum += fitted;
    sum2 += fitted * fitted;
  }
  const double mean = sum / draws, se = std::sqrt((sum2 / draws - mean * mean) / draws);
  std::printf("negative bins %.1f %%; fitted PSD at the 4th bin / truth: %.3f +- %.3f\n", 100.0 * negative / (6.0 * draws),
              mean / truth, se / truth);
  EXPECT_GT(negative, 6 * draws / 4);  // the case: about 31 % of the bins negative
  EXPECT_LT(std::abs(mean - truth), 4.0 * se + 0.1 * truth);
}

TEST(FitWhiteAndPink, StatesTheCovarianceOfItsLevels) {
  // The pair's bins (6 log-spaced over 0.03-0.25 Hz at 1 s) with the simulator's reference noise
  // (white 0.01 nT, 1/f 0.005 nT/sqrt(Hz): the two terms comparable there). 400 sets, each bin
  // the truth plus Gaussian noise of a stated sd (25 % of the bin in the lowest, 5 % in the
  // top, as two days of the quiet station give): the fitted w^2 and p^2 scatter about the truth
  // as the stated covariance says, and the correlation between them is the stated one (the two
  // terms trade off across the bins).
  Bins b;
  b.low.clear();
  b.high.clear();
  for (int k = 0; k < 6; ++k) {
    b.low.push_back(0.03 * std::pow(0.25 / 0.03, k / 6.0));
    b.high.push_back(0.03 * std::pow(0.25 / 0.03, (k + 1) / 6.0));
  }
  const Eigen::Vector3d w = Eigen::Vector3d::Constant(0.01), p = Eigen::Vector3d::Constant(0.005);
  const std::vector<Eigen::Vector3d> truth = b.psd(w, p, 1.0);
  std::vector<Eigen::Vector3d> sd;
  for (std::size_t k = 0; k < truth.size(); ++k) sd.push_back(truth[k] * (0.25 - 0.04 * static_cast<double>(k)));
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Vector2d z2 = Eigen::Vector2d::Zero();
  double cross = 0.0, stated_correlation = 0.0;
  const int draws = 400;
  for (int d = 0; d < draws; ++d) {
    std::vector<Eigen::Vector3d> psd = truth;
    for (std::size_t k = 0; k < psd.size(); ++k)
      for (int c = 0; c < 3; ++c) psd[k](c) += sd[k](c) * normal(rng);
    Eigen::Vector3d white, pink;
    mic::NoiseLevelCovariance cov;
    mic::fit_white_and_pink(psd, sd, b.low, b.high, 1.0, white, pink, &cov);
    const Eigen::Vector2d e(white(0) * white(0) - w(0) * w(0), pink(0) * pink(0) - p(0) * p(0));
    const Eigen::Vector2d z(e(0) / std::sqrt(cov[0](0, 0)), e(1) / std::sqrt(cov[0](1, 1)));
    z2 += z.cwiseAbs2();
    cross += z(0) * z(1);
    stated_correlation += cov[0](0, 1) / std::sqrt(cov[0](0, 0) * cov[0](1, 1));
  }
  const Eigen::Vector2d rms = (z2 / draws).cwiseSqrt();
  std::printf("rms z of w^2, p^2: %.3f %.3f; correlation %.2f (stated %.2f)\n", rms(0), rms(1), cross / draws,
              stated_correlation / draws);
  for (int j = 0; j < 2; ++j) {
    EXPECT_GT(rms(j), 0.85) << j;
    EXPECT_LT(rms(j), 1.2) << j;
  }
  EXPECT_NEAR(cross / draws, stated_correlation / draws, 0.15);
  // One standard deviation per bin is needed.
  Eigen::Vector3d white, pink;
  mic::NoiseLevelCovariance cov;
  try {
    mic::fit_white_and_pink(truth, {}, b.low, b.high, 1.0, white, pink, &cov);
    FAIL() << "missing standard deviations accepted";
  } catch (const mic::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("fit_white_and_pink"), std::string::npos) << e.what();
  }
}

namespace {

struct ThreeInstruments {
  mic::SimulatedPair pair;
  mic::VectorRecord third;
  mic::SimulationSettings settings;
};

/// Two days at 1 Hz: reference white 0.1 nT + 1/f 0.02 nT/sqrt(Hz) at 1 Hz, test white 0.01 nT,
/// third white 0.05 nT with its own small misalignment; the third starts 2 h late.
ThreeInstruments three_instruments(std::uint64_t seed) {
  ThreeInstruments t;
  mic::SimulationSettings& s = t.settings;
  s.seed = seed;
  s.duration_s = 2.0 * 86400.0;
  s.reference_white_nT = 0.1;
  s.reference_pink_nT_per_sqrt_hz = 0.02;
  s.test_white_nT = 0.01;
  s.test_pink_nT_per_sqrt_hz = 0.0;
  s.keep_clean_field = true;
  t.pair = mic::simulate_pair(s);
  const Eigen::Index skip = 7200;
  const Eigen::Index rows = t.pair.field_nT.rows() - skip;
  t.third.values_nT = mic::co_located_instrument(t.pair.field_nT.bottomRows(rows), mic::co_located_instrument_matrix(),
                                                 0.05, seed * 31 + 7);
  t.third.time_s.assign(t.pair.reference.time_s.begin() + skip, t.pair.reference.time_s.end());
  return t;
}

/// A third record on the pair's estimation epochs, whole, as calibrate_records --third brings it
/// there (prepare_sides) before each window takes its epochs.
mic::VectorRecord third_on_epochs(const mic::VectorRecord& reference, const mic::PreparedPair& pair,
                                  const mic::VectorRecord& third) {
  const mic::PreparedSides sides = mic::prepare_sides(reference, pair, {&third}, mic::CalibrationSettings{});
  return sides.third->on_epochs(-std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity());
}

}  // namespace

TEST(IdentifyReferenceNoise, RecoversTheReferenceNoiseOfThreeInstruments) {
  // MIC_HAT_SEED: another seed (seeds 91-110 checked when written).
  const char* seed = std::getenv("MIC_HAT_SEED");
  const ThreeInstruments t = three_instruments(seed != nullptr ? std::strtoull(seed, nullptr, 10) : 91);
  const mic::PreparedPair with_test = mic::prepare_pair(t.pair.reference, t.pair.test, mic::PreprocessSettings{});
  const mic::IdentifiedNoise noise = mic::identify_reference_noise(
      with_test.paired, third_on_epochs(t.pair.reference, with_test, t.third), 1.0, 0.0002, 0.01, 4, "--third");
  ASSERT_TRUE(noise.identified) << noise.text;
  EXPECT_EQ(noise.samples, t.third.time_s.size());  // the epochs all three share
  EXPECT_NE(noise.text.find("three-cornered hat"), std::string::npos) << noise.text;
  // The identified noise level (ASD, the square root of the fitted PSD) against the simulated one
  // in every bin of the band, every axis: within 20 % (the aim for each instrument's level). The lowest bin holds 56 harmonics: its periodogram alone scatters by about 13 % in PSD.
  const Bins b;
  const std::vector<Eigen::Vector3d> truth =
      b.psd(Eigen::Vector3d::Constant(0.1), Eigen::Vector3d::Constant(0.02), 1.0);
  const std::vector<Eigen::Vector3d> fitted = b.psd(noise.white_nT, noise.pink_nT_per_sqrt_hz, 1.0);
  for (std::size_t k = 0; k < truth.size(); ++k) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(std::sqrt(fitted[k](c) / truth[k](c)), 1.0, 0.2) << "bin " << k << ", axis " << c << ": " << noise.text;
    }
  }
}

TEST(IdentifyReferenceNoise, RecoversTheQuietTestsLevelFromTheBinsAboveTheBand) {
  // Each instrument's noise level, the quietest too: one day at 1 Hz, white noise
  // 0.1 nT in the reference, 0.01 nT in the test, 0.05 nT in the third (the node benchmark's
  // instruments). The quiet test's estimate scatters by the others' noise, sqrt(N_r N_c / 2 /
  // harmonics), not by its own. Its level as a maker states it, the fitted ASD at the top of the
  // bins (0.15-0.25 Hz; white-equivalent, nT rms per sample at 1 s): there the hat's bins now
  // reach (21 600 harmonics over 0.01-0.25 Hz, about 12 % scatter in the level), weighted by
  // harmonics and by that floor; over the band alone (about 850 harmonics a day) it was
  // undetermined. Over 5 seeds x 3 axes: the mean within 10 % (its own scatter about 3 %), every
  // level within 40 % (3 standard deviations). Its level averaged over the band is not held to
  // this: a 1/f term of 0.8 pT/sqrt(Hz), within the lowest bins' scatter, doubles it there.
  double sum = 0.0;
  int values = 0;
  for (std::uint64_t seed = 94; seed < 99; ++seed) {
    mic::SimulationSettings s;
    s.seed = seed;
    s.reference_white_nT = 0.1;
    s.test_white_nT = 0.01;
    s.reference_pink_nT_per_sqrt_hz = s.test_pink_nT_per_sqrt_hz = 0.0;
    s.keep_clean_field = true;
    const mic::SimulatedPair pair = mic::simulate_pair(s);
    mic::VectorRecord third;
    third.time_s = pair.reference.time_s;
    third.values_nT = mic::co_located_instrument(pair.field_nT, mic::co_located_instrument_matrix(), 0.05, seed * 31 + 7);
    const mic::PreparedPair with_test = mic::prepare_pair(pair.reference, pair.test, mic::PreprocessSettings{});
    const mic::IdentifiedNoise noise = mic::identify_reference_noise(
        with_test.paired, third_on_epochs(pair.reference, with_test, third), 1.0, 0.0002, 0.01, 4, "--third");
    ASSERT_TRUE(noise.identified) << noise.text;
    ASSERT_FALSE(noise.hat.bin_high_hz.empty());
    const double top = noise.hat.bin_high_hz.back(), below = noise.hat.bin_low_hz.back();
    EXPECT_NEAR(top, 0.25, 1e-12);  // above the band, to 0.25 Hz at 1 s
    Eigen::Vector3d white, pink;
    ASSERT_TRUE(mic::fit_hat_instrument(noise.hat, 1, 1.0, white, pink));
    const double inverse_f = std::log(top / below) / (top - below);  // mean 1/f over the top bin
    for (int c = 0; c < 3; ++c) {
      const double level = std::sqrt(white(c) * white(c) + 0.5 * inverse_f * pink(c) * pink(c)) / 0.01;  // dt = 1 s
      std::printf("seed %llu axis %d: test's level at the top bin / simulated %.3f\n", static_cast<unsigned long long>(seed), c, level);
      EXPECT_NEAR(level, 1.0, 0.4) << "seed " << seed << " axis " << c;
      sum += level;
      ++values;
    }
  }
  std::printf("mean level / simulated over %d values: %.3f\n", values, sum / values);
  EXPECT_NEAR(sum / values, 1.0, 0.1);
}

TEST(IdentifyReferenceNoise, AThirdRecordOutsideThePairIsNamed) {
  ThreeInstruments t = three_instruments(92);
  for (double& time : t.third.time_s) time += 2.0 * 86400.0;  // two days later: no shared epoch
  try {
    mic::calibrate_records(t.pair.reference, t.pair.test, mic::CalibrationSettings{}, {&t.third});
    FAIL() << "no error";
  } catch (const mic::InputError& e) {
    EXPECT_EQ(e.where(), "--third") << e.what();
    EXPECT_NE(std::string(e.what()).find("overlap"), std::string::npos) << e.what();
  }
}

namespace {

/// The pair (reference, test) and the third as calibration_node's windows hold them: on the 1 Hz
/// grid, the reference's epochs, NaN where an instrument has no sample.
struct GridPairs {
  mic::PairedRecord with_test;
  mic::VectorRecord with_third;
};

GridPairs grid_pairs(const ThreeInstruments& t) {
  GridPairs g;
  const Eigen::Index rows = t.pair.reference.values_nT.rows();
  const Eigen::Index skip = rows - t.third.values_nT.rows();
  g.with_test.time_s = t.pair.reference.time_s;
  g.with_test.reference_nT = t.pair.reference.values_nT;
  g.with_test.test_nT = t.pair.test.values_nT;
  g.with_third.time_s = t.pair.reference.time_s;
  g.with_third.values_nT = t.pair.test.values_nT;
  g.with_third.values_nT.topRows(skip).setConstant(std::numeric_limits<double>::quiet_NaN());
  g.with_third.values_nT.bottomRows(rows - skip) = t.third.values_nT;
  return g;
}

}  // namespace

TEST(IdentifyReferenceNoise, OnLiveWindowsWithMissingSamplesUsesTheLongestRunAllThreeShare) {
  // The form calibration_node uses: two paired records on one grid, NaN = missing. A missing
  // test sample 3 h after the third starts splits the shared epochs; the longer run is used.
  const ThreeInstruments t = three_instruments(93);
  GridPairs g = grid_pairs(t);
  const Eigen::Index skip = g.with_test.reference_nT.rows() - t.third.values_nT.rows();
  g.with_test.test_nT(skip + 3 * 3600, 1) = std::numeric_limits<double>::quiet_NaN();
  const mic::IdentifiedNoise noise = mic::identify_reference_noise(g.with_test, g.with_third, 1.0, 0.0002, 0.01, 4, "test 'b'");
  ASSERT_TRUE(noise.identified) << noise.text;
  EXPECT_EQ(noise.samples, static_cast<std::size_t>(g.with_test.reference_nT.rows() - skip - 3 * 3600 - 1));
  EXPECT_NE(noise.text.find("with test 'b'"), std::string::npos) << noise.text;
  // The same simulated reference noise as above (white 0.1 nT, 1/f 0.02 nT/sqrt(Hz)): its ASD at
  // the band's middle bin within 20 %.
  const Bins b;
  const double truth = b.psd(Eigen::Vector3d::Constant(0.1), Eigen::Vector3d::Constant(0.02), 1.0)[2](0);
  const std::vector<Eigen::Vector3d> fitted = b.psd(noise.white_nT, noise.pink_nT_per_sqrt_hz, 1.0);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(std::sqrt(fitted[2](c) / truth), 1.0, 0.2) << c << ": " << noise.text;
}

TEST(IdentifyReferenceNoise, TheSameTestRecordTwiceIsSharedNoiseAndIdentifiesNothing) {
  // Two "tests" that are one record (a copied topic): the hat gives them no noise of their own
  // and would put all of it on the reference; nothing is identified, and the text says why.
  const ThreeInstruments t = three_instruments(94);
  GridPairs g = grid_pairs(t);
  g.with_third.values_nT = g.with_test.test_nT;
  const mic::IdentifiedNoise noise = mic::identify_reference_noise(g.with_test, g.with_third, 1.0, 0.0002, 0.01, 4, "test 'b'");
  EXPECT_FALSE(noise.identified) << noise.text;
  EXPECT_EQ(noise.white_nT, Eigen::Vector3d::Zero());
  EXPECT_EQ(noise.pink_nT_per_sqrt_hz, Eigen::Vector3d::Zero());
  EXPECT_NE(noise.text.find("one record twice"), std::string::npos) << noise.text;
}

TEST(IdentifyReferenceNoise, TooFewSharedEpochsNameTheThird) {
  const ThreeInstruments t = three_instruments(95);
  GridPairs g = grid_pairs(t);
  for (Eigen::Index i = 0; i < g.with_third.values_nT.rows(); i += 50) g.with_third.values_nT(i, 0) = std::nan("");
  try {
    mic::identify_reference_noise(g.with_test, g.with_third, 1.0, 0.0002, 0.01, 4, "test 'b'");
    FAIL() << "no error";
  } catch (const mic::InputError& e) {
    EXPECT_EQ(e.where(), "test 'b'") << e.what();
    EXPECT_NE(std::string(e.what()).find("49 consecutive epochs"), std::string::npos) << e.what();
  }
}

namespace {

/// Two quiet days at 1 Hz whose reference is 5x noisier than the test (white 50 pT, 1/f
/// 25 pT/sqrt(Hz) at 1 Hz; test 10 pT, 5 pT/sqrt(Hz)): Eq. 2's attenuation of the weak z is
/// several of its standard errors.
mic::SimulatedPair noisy_reference_pair(std::uint64_t seed) {
  mic::SimulationSettings s;
  s.seed = seed;
  s.duration_s = 2.0 * 86400.0;
  s.reference_white_nT = 0.05;
  s.reference_pink_nT_per_sqrt_hz = 0.025;
  return mic::simulate_pair(s);
}

}  // namespace

TEST(IdentifyReferenceNoiseFromPair, TheDefaultCorrectsTheAttenuationWithoutAFigure) {
  // MIC_PAIR_SEED: another seed (51-60 checked when written).
  const char* seed = std::getenv("MIC_PAIR_SEED");
  const mic::SimulatedPair pair = noisy_reference_pair(seed != nullptr ? std::strtoull(seed, nullptr, 10) : 51);
  const Eigen::Vector3d truth = mic::decompose(pair.n_true).scale_ratio;
  mic::CalibrationSettings off;
  off.window.pair_noise = false;
  const mic::CalibrationWindow before = mic::calibrate_records(pair.reference, pair.test, off).windows.back();
  const mic::CalibrationWindow after = mic::calibrate_records(pair.reference, pair.test, {}).windows.back();
  EXPECT_TRUE(before.reference_noise.text.empty());
  EXPECT_EQ(before.estimate.eiv, mic::ErrorsInVariables::kNoNoiseModel) << before.estimate.eiv_text();
  EXPECT_NE(after.reference_noise.text.find("from the pair above the band"), std::string::npos) << after.reference_noise.text;
  EXPECT_EQ(after.estimate.eiv, mic::ErrorsInVariables::kApplied);
  EXPECT_EQ(after.estimate.eiv_noise.source, mic::NoiseSource::kPairAboveBand);
  EXPECT_NE(after.estimate.eiv_text().find("from the pair above the band"), std::string::npos) << after.estimate.eiv_text();
  double before_z2 = 0.0, after_z2 = 0.0;
  // Without the correction, the attenuation in units of n's own standard errors: before the band
  // halves' spread (halves_split.hpp), which carries part of it.
  const mic::CalibrationParameters own_before =
      mic::decompose(before.estimate.n, before.estimate.n_covariance - before.estimate.band_split.spread_covariance,
                     before.estimate.covariance_dof);
  for (int c = 0; c < 3; ++c) {
    const mic::CalibrationParameters& pb = own_before;
    const mic::CalibrationParameters& pa = after.estimate.parameters;
    const double se_before = pb.scale_ratio_ci95(c) / pb.interval_quantile;
    const double se_after = pa.scale_ratio_ci95(c) / pa.interval_quantile;
    before_z2 += std::pow((before.estimate.parameters.scale_ratio(c) - truth(c)) / se_before, 2) / 3.0;
    after_z2 += std::pow((after.estimate.parameters.scale_ratio(c) - truth(c)) / se_after, 2) / 3.0;
  }
  // Eq. 2's attenuation, 6-9 standard errors rms over the three scale ratios without the
  // correction on seeds 51-60, falls to 0.5-2.4 with it: what is left is the fitted noise's
  // extrapolation from above the band into it, with a reference 5x noisier than the test.
  EXPECT_GT(std::sqrt(before_z2), 3.0);
  EXPECT_LT(std::sqrt(after_z2), 2.5);
  EXPECT_LT(std::sqrt(after_z2), std::sqrt(before_z2) / 3.0);
}

TEST(IdentifyReferenceNoiseFromPair, NotFromATestBehindAModelledFilter) {
  // Above the band the field's part of the reference's PSD is tens of times its noise; with a
  // modelled corner there its error would be taken for noise: nothing identified, and said why.
  mic::SimulationSettings s;  // the simulator's quiet station, equal noise in both
  s.seed = 52;
  s.duration_s = 2.0 * 86400.0;
  mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::apply_test_response(pair.test.values_nT, 1.0, 0.03, 0.0);
  const mic::CalibrationWindow w = mic::calibrate_records(pair.reference, pair.test, {}).windows.back();
  mic::CalibrationSettings off;
  off.window.pair_noise = false;
  const mic::CalibrationWindow without = mic::calibrate_records(pair.reference, pair.test, off).windows.back();
  ASSERT_TRUE(w.response_model.applied) << w.response_model.text;
  // Refused means untouched: n is the one estimated without the step, to the bit.
  EXPECT_EQ(w.estimate.n, without.estimate.n);
  EXPECT_NE(w.reference_noise.text.find("not identified from the pair: the test's filter is modelled"), std::string::npos)
      << w.reference_noise.text;
  EXPECT_EQ(w.estimate.eiv, mic::ErrorsInVariables::kNoNoiseModel) << w.estimate.eiv_text();
}
