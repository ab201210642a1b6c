// Errors in variables: the noise spectrum's units, the corrected solve, and the removal of the
// attenuation of Eq. 2 by a noisy reference.
#include "magnetometer_insitu_calibration/estimation/errors_in_variables.hpp"
#include "magnetometer_insitu_calibration/estimation/robust/robust_estimator.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <gtest/gtest.h>

#include <Eigen/LU>

#include <cmath>
#include <random>

namespace mic = magnetometer_insitu_calibration;

namespace {

/// The window's inputs with a reference noise model of these levels on every axis.
mic::WindowInputs given_noise(double white_nT, double pink_nT_per_sqrt_hz,
                              mic::NoiseSource source = mic::NoiseSource::kMakerFigure) {
  mic::WindowInputs inputs;
  inputs.reference_noise.source = source;
  inputs.reference_noise.spectrum.white_nT.setConstant(white_nT);
  inputs.reference_noise.spectrum.pink_nT_per_sqrt_hz.setConstant(pink_nT_per_sqrt_hz);
  return inputs;
}

}  // namespace

TEST(ErrorsInVariables, ExpectedPeriodogramOfWhiteNoiseIsLengthTimesVariance) {
  mic::NoiseSpectrum noise;
  noise.white_nT = Eigen::Vector3d(0.1, 0.2, 0.0);
  noise.pink_nT_per_sqrt_hz = Eigen::Vector3d(0.0, 0.0, 0.05);
  const Eigen::Vector3d psd = noise.psd(0.01, 1.0);
  EXPECT_NEAR(psd(0), 2.0 * 0.01, 1e-15);          // 2 sigma^2 dt
  EXPECT_NEAR(psd(2), 0.0025 / 0.01, 1e-12);        // level^2 / f
  const Eigen::Vector3d p = noise.expected_periodogram(0.01, 1.0, 1000);
  EXPECT_NEAR(p(0), 1000 * 0.01, 1e-9);             // E|X_j|^2 = L sigma^2 for white noise
  // Against an average of simulated periodograms (white, sigma 0.1, L = 256, dt = 0.5 s).
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal(0.0, 0.1);
  double sum = 0.0;
  const int trials = 4000, length = 256, j = 20;
  for (int t = 0; t < trials; ++t) {
    std::complex<double> x = 0.0;
    for (int i = 0; i < length; ++i) x += normal(rng) * std::polar(1.0, -2.0 * M_PI * j * i / length);
    sum += std::norm(x);
  }
  const double expected = noise.expected_periodogram(j / (length * 0.5), 0.5, length)(0);
  EXPECT_NEAR(sum / trials / expected, 1.0, 0.05);
}

TEST(ErrorsInVariables, WhatWasAppliedIsNamedAndPrintedByOneFormatter) {
  const mic::ReferenceNoiseModel none;
  EXPECT_FALSE(none.has_noise());
  const mic::ReferenceNoiseModel figure =
      mic::ReferenceNoiseModel::maker_figure(mic::NoiseSpectrum::fluxgate_figure(10.0));  // pT/sqrt(Hz)
  EXPECT_TRUE(figure.has_noise());
  EXPECT_EQ(figure.source, mic::NoiseSource::kMakerFigure);
  EXPECT_DOUBLE_EQ(figure.spectrum.pink_nT_per_sqrt_hz(2), 0.010);
  EXPECT_FALSE(mic::ReferenceNoiseModel::maker_figure(mic::NoiseSpectrum::fluxgate_figure(0.0)).has_noise());
  EXPECT_EQ(mic::errors_in_variables_text(mic::ErrorsInVariables::kNotApplicable, none), "none (plain Eq. 2)");
  EXPECT_EQ(mic::errors_in_variables_text(mic::ErrorsInVariables::kNoNoiseModel, none),
            "none (no reference noise model)");
  EXPECT_EQ(mic::errors_in_variables_text(mic::ErrorsInVariables::kApplied, figure),
            "reference noise from the maker's figure: white 0/0/0 pT rms, 1/f 10/10/10 pT/sqrt(Hz) at 1 Hz (x/y/z)");
  mic::ReferenceNoiseModel hat = figure;
  hat.source = mic::NoiseSource::kThreeCorneredHat;
  hat.provider = "test 'b'";
  EXPECT_NE(mic::errors_in_variables_text(mic::ErrorsInVariables::kApplied, hat)
                .find("three-cornered hat with test 'b'"),
            std::string::npos);
  EXPECT_STREQ(mic::errors_in_variables_name(mic::ErrorsInVariables::kRefused), "refused");
  mic::ReferenceNoiseModel bad = figure;
  bad.spectrum.white_nT(1) = -1.0;
  EXPECT_THROW(bad.validate(), mic::InputError);
}

TEST(ErrorsInVariables, CorrectedSolveUndoesAKnownAttenuation) {
  Eigen::Matrix3d signal;
  signal << 4.0, 0.5, 0.1, 0.5, 3.0, 0.2, 0.1, 0.2, 1.0;
  const Eigen::Matrix3d noise = Eigen::Vector3d(0.1, 0.1, 0.3).asDiagonal();
  Eigen::Matrix3d n;
  n << 1.0004, 0.001, -0.002, 0.0005, 0.9996, 0.003, 0.001, -0.001, 1.0002;
  const Eigen::MatrixXd a = signal + noise;  // expected sums of Eq. 2
  const Eigen::MatrixXd c = signal * n;
  const Eigen::Matrix3d plain = a.inverse() * c;
  EXPECT_NEAR((plain - (n - mic::eiv_attenuation(signal, noise) * n)).cwiseAbs().maxCoeff(), 0.0, 1e-12);
  Eigen::MatrixXd corrected;
  ASSERT_TRUE(mic::corrected_solve(a, noise, c, corrected));
  EXPECT_LT((corrected - n).cwiseAbs().maxCoeff(), 1e-12);
  Eigen::MatrixXd unused;
  EXPECT_FALSE(mic::corrected_solve(a, Eigen::Matrix3d(5.0 * Eigen::Matrix3d::Identity()), c, unused));
}

TEST(ErrorsInVariables, NoisyReferenceAttenuatesEq2AndTheCorrectionRemovesIt) {
  // Reference noise x10 (white 0.1 nT, pink 0.05 nT/sqrt(Hz)); 6 days averaged, so that the mean
  // error resolves the bias. The z scale ratio suffers most (weakest signal).
  Eigen::Vector3d plain_error = Eigen::Vector3d::Zero(), given_error = plain_error, se = plain_error;
  const int seeds = 6;
  for (int k = 0; k < seeds; ++k) {
    mic::SimulationSettings s;
    s.seed = 70 + k;
    s.keep_clean_field = false;
    s.reference_white_nT = 0.1;
    s.reference_pink_nT_per_sqrt_hz = 0.05;
    const mic::SimulatedPair pair = mic::simulate_pair(s);
    const Eigen::Vector3d truth = mic::decompose(pair.n_true).scale_ratio;
    mic::EstimatorSettings es;
    es.method = mic::EstimatorMethod::kPlain;
    plain_error += mic::WindowEstimator(es).estimate(pair.reference.values_nT, pair.test.values_nT, 1.0).parameters.scale_ratio - truth;
    es.method = mic::EstimatorMethod::kRobust;
    const mic::WindowEstimate g =
        mic::WindowEstimator(es).estimate(pair.reference.values_nT, pair.test.values_nT, 1.0, given_noise(0.1, 0.05));
    ASSERT_EQ(g.eiv, mic::ErrorsInVariables::kApplied);
    given_error += g.parameters.scale_ratio - truth;
    se += g.parameters.scale_ratio_ci95 / g.parameters.interval_quantile;
  }
  plain_error /= seeds;
  given_error /= seeds;
  se /= seeds;
  const Eigen::Vector3d se_of_mean = se / std::sqrt(double(seeds));
  // Eq. 2 is attenuated (negative error) by many standard errors of the mean in z.
  EXPECT_LT(plain_error(2), -8.0 * se_of_mean(2)) << plain_error.transpose() << " se " << se.transpose();
  for (int l = 0; l < 3; ++l) {
    EXPECT_LT(std::abs(given_error(l)), 3.5 * se_of_mean(l)) << l << ": " << given_error.transpose();
  }
}

TEST(ErrorsInVariables, CorrectedWindowsOfANoisyReferenceCoverTheTruth) {
  // Reference noise x10 (white and pink alike), its true spectrum as the noise model: the
  // corrected estimate's intervals must hold the truth (the correction moves n by many of the
  // uncorrected estimate's standard errors in z).
  const int seeds = 10;
  double z2_sum = 0.0;
  int covered = 0, checked = 0;
  for (int k = 0; k < seeds; ++k) {
    mic::SimulationSettings s;
    s.seed = 900 + k;
    s.keep_clean_field = false;
    s.variation_rms_nT = 5.0;
    s.reference_white_nT *= 10.0;
    s.reference_pink_nT_per_sqrt_hz *= 10.0;
    const mic::SimulatedPair pair = mic::simulate_pair(s);
    const mic::CalibrationParameters truth = mic::decompose(pair.n_true);
    mic::RobustFdEstimator given{mic::EstimatorSettings{}};
    const mic::WindowEstimate e = given.estimate(pair.reference.values_nT, pair.test.values_nT, 1.0,
                                                 given_noise(s.reference_white_nT, s.reference_pink_nT_per_sqrt_hz));
    ASSERT_TRUE(given.diagnostics().eiv_applied);
    const double se_z = e.parameters.scale_ratio_ci95(2) / e.parameters.interval_quantile;
    z2_sum += std::pow((e.parameters.scale_ratio(2) - truth.scale_ratio(2)) / se_z, 2);
    for (int l = 0; l < 3; ++l) {
      covered += std::abs(e.parameters.scale_ratio(l) - truth.scale_ratio(l)) <= e.parameters.scale_ratio_ci95(l);
      covered += std::abs(e.parameters.nonorthogonality_deg(l) - truth.nonorthogonality_deg(l)) <=
                 e.parameters.nonorthogonality_ci95_deg(l);
      covered += std::abs(e.parameters.misalignment_deg(l) - truth.misalignment_deg(l)) <=
                 e.parameters.misalignment_ci95_deg(l);
      checked += 3;
    }
  }
  const double coverage = static_cast<double>(covered) / checked;
  std::printf("mean (z error / se)^2 %.2f; coverage %.3f\n", z2_sum / seeds, coverage);
  EXPECT_LT(z2_sum / seeds, 2.5);  // about 1 when honest
  EXPECT_GE(coverage, 0.88);
}

TEST(ErrorsInVariables, TheGivenLevelsUncertaintyEntersTheCovarianceAsBruteForceSays) {
  // A given noise with a stated uncertainty of its levels (as the pair above the band states
  // it): the covariance term the estimator adds must match the one from refitting n with each
  // level moved by +-1 standard deviation (central differences), and a zero covariance (a
  // maker's figure) must leave the covariance exactly as it was.
  mic::SimulationSettings s;
  s.seed = 77;
  s.keep_clean_field = false;
  s.reference_white_nT = 0.1;
  s.reference_pink_nT_per_sqrt_hz = 0.05;
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::EstimatorSettings es;
  const mic::WindowInputs figure = given_noise(0.1, 0.05);
  mic::RobustFdEstimator exact(es);
  const mic::WindowEstimate e0 = exact.estimate(pair.reference.values_nT, pair.test.values_nT, 1.0, figure);
  ASSERT_TRUE(exact.diagnostics().eiv_applied);
  EXPECT_TRUE(exact.diagnostics().covariance_noise_levels.isZero(0.0));
  EXPECT_EQ(e0.intervals.find("identified reference noise"), std::string::npos) << e0.intervals;

  // Level standard deviations: 20 % of w^2 and 30 % of p^2, uncorrelated; x and z only.
  const Eigen::Vector2d sd(0.2 * 0.1 * 0.1, 0.3 * 0.05 * 0.05);
  mic::WindowInputs uncertain = given_noise(0.1, 0.05, mic::NoiseSource::kPairAboveBand);
  for (int c : {0, 2}) uncertain.reference_noise.level_covariance[static_cast<std::size_t>(c)] = sd.cwiseAbs2().asDiagonal();
  mic::RobustFdEstimator with(es);
  const mic::WindowEstimate e1 = with.estimate(pair.reference.values_nT, pair.test.values_nT, 1.0, uncertain);
  EXPECT_EQ((e1.n - e0.n).cwiseAbs().maxCoeff(), 0.0);  // the levels themselves are the same
  EXPECT_NE(e1.intervals.find("identified reference noise"), std::string::npos) << e1.intervals;
  const mic::Matrix9d term = with.diagnostics().covariance_noise_levels;
  // Each window's own covariance before the band halves' spread (halves_split.hpp), which the
  // level term moves through the halves' covariances.
  const mic::Matrix9d own0 = e0.n_covariance - e0.band_split.spread_covariance;
  const mic::Matrix9d own1 = e1.n_covariance - e1.band_split.spread_covariance;
  EXPECT_LT((own1 - own0 - term).cwiseAbs().maxCoeff(), 1e-12 * own0.cwiseAbs().maxCoeff());

  // Brute force: n refitted (weights re-chosen, as a real change of levels would) at each level
  // +-1 sd; the variance of vec(n) entry k is sum over (axis, level) of (dn_k/dlevel sd)^2.
  Eigen::Matrix<double, 9, 1> brute = Eigen::Matrix<double, 9, 1>::Zero();
  for (int c : {0, 2}) {
    for (int j = 0; j < 2; ++j) {
      Eigen::Matrix3d n_at[2];
      for (int side = 0; side < 2; ++side) {
        mic::WindowInputs moved = figure;
        const double sign = side == 0 ? 1.0 : -1.0;
        if (j == 0) moved.reference_noise.spectrum.white_nT(c) = std::sqrt(0.1 * 0.1 + sign * sd(0));
        else moved.reference_noise.spectrum.pink_nT_per_sqrt_hz(c) = std::sqrt(0.05 * 0.05 + sign * sd(1));
        n_at[side] = mic::RobustFdEstimator(es).estimate(pair.reference.values_nT, pair.test.values_nT, 1.0, moved).n;
      }
      const Eigen::Matrix3d dn = 0.5 * (n_at[0] - n_at[1]);
      for (int r = 0; r < 3; ++r)
        for (int q = 0; q < 3; ++q) brute(3 * r + q) += dn(r, q) * dn(r, q);
    }
  }
  for (int k = 0; k < 9; ++k) {
    // Entries whose level-driven standard deviation is under 1 % of the largest's: there the
    // weights the brute-force refits re-choose, not the levels, make most of the difference
    // (measured with the per-section trend column: n(2,1) at 0.84 % of the largest sd, term /
    // brute force 0.89; n(0,1) at 0.2 %, 0.95; every other entry 0.99-1.00).
    if (brute(k) < 1e-4 * brute.maxCoeff()) continue;
    EXPECT_NEAR(std::sqrt(term(k, k) / brute(k)), 1.0, 0.1) << "entry " << k;
  }
  // The term is not negligible here: x's scale-ratio variance grows by more than 5 %.
  EXPECT_GT(term(0, 0), 0.05 * e0.n_covariance(0, 0));
}
