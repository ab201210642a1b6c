// The per-window stage (pipeline/window_calibration.hpp) that calibrate_records and
// calibration_node share: the gap rule, the temperature terms with a simulated hut temperature,
// the response model of a test behind a filter, the reference noise from a third instrument
// (three-cornered hat) or from the pair above the band, and spikes.
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "magnetometer_insitu_calibration/pipeline/window_calibration.hpp"
#include "magnetometer_insitu_calibration/preprocessing/despike.hpp"
#include "magnetometer_insitu_calibration/simulation/co_located_instrument.hpp"
#include "magnetometer_insitu_calibration/simulation/hut_temperature.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "magnetometer_insitu_calibration/simulation/unmodelled_disturbances.hpp"

#include "../hut_fixture.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <utility>

namespace mic = magnetometer_insitu_calibration;

namespace {

/// Plain Eq. 2 as printed: no modelled filter, no errors-in-variables correction.
mic::WindowCalibrationSettings plain_settings() {
  mic::WindowCalibrationSettings s;
  s.estimator.method = mic::EstimatorMethod::kPlain;
  s.response_model = false;
  return s;
}

/// The default robust estimator without the reference noise identified from the pair (and,
/// with hat, still from a third instrument): what a test of another step compares against.
mic::WindowCalibrationSettings without_noise_identification(bool hat = false) {
  mic::WindowCalibrationSettings s;
  s.pair_noise = false;
  s.three_cornered_hat = hat;
  return s;
}

}  // namespace

namespace {

mic::WindowRecords simulated_window(double duration_s, std::uint64_t seed, mic::SimulatedPair* pair_out = nullptr) {
  mic::SimulationSettings s;
  s.duration_s = duration_s;
  s.seed = seed;
  mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::WindowRecords w;
  w.start_s = pair.reference.time_s.front();
  w.period_s = 1.0;
  w.expected_samples = pair.reference.size();
  w.paired.time_s = pair.reference.time_s;
  w.paired.reference_nT = pair.reference.values_nT;
  w.paired.test_nT = pair.test.values_nT;
  if (pair_out != nullptr) *pair_out = pair;
  return w;
}

mic::WindowRecords without_rows(const mic::WindowRecords& w, std::size_t first, std::size_t count) {
  mic::WindowRecords out = w;
  const std::size_t n = w.paired.size(), keep = n - count;
  out.paired.time_s.clear();
  out.paired.reference_nT.resize(static_cast<Eigen::Index>(keep), 3);
  out.paired.test_nT.resize(static_cast<Eigen::Index>(keep), 3);
  Eigen::Index row = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (i >= first && i < first + count) continue;
    out.paired.time_s.push_back(w.paired.time_s[i]);
    out.paired.reference_nT.row(row) = w.paired.reference_nT.row(static_cast<Eigen::Index>(i));
    out.paired.test_nT.row(row) = w.paired.test_nT.row(static_cast<Eigen::Index>(i));
    ++row;
  }
  return out;
}

}  // namespace

TEST(WindowCalibration, CompleteWindowIsAcceptedAndGapsAreFlagged) {
  mic::SimulatedPair pair;
  const mic::WindowRecords full = simulated_window(7200.0, 5, &pair);
  mic::WindowCalibrator estimator(plain_settings());  // gap rule 3600 s, 5 %
  const mic::CalibrationWindow ok = estimator.calibrate(full);
  EXPECT_EQ(ok.estimate.quality, mic::Quality::kOk) << ok.estimate.quality_text;
  EXPECT_EQ(ok.missing(), 0u);
  const Eigen::Matrix3d z = (ok.estimate.n - pair.n_true).cwiseAbs().array() / ok.estimate.n_stderr().array();
  EXPECT_LT(z.maxCoeff(), 4.0) << "|n - n_true| / se:\n" << z << "\nse:\n" << ok.estimate.n_stderr();
  const Eigen::Vector3d mean_r = full.paired.reference_nT.colwise().mean().transpose();
  EXPECT_LT((ok.reference_mean_nT - mean_r).norm(), 1e-9) << ok.reference_mean_nT.transpose();
  // The simulated pair has no relative filter or delay: its response over the band is flat (for
  // the diagnostics' summary) within the half-width and the group delay is near 0 s.
  ASSERT_GT(ok.response.bands, 0u);
  EXPECT_LE(ok.response.max_gain_departure, 2.0 * ok.response.max_gain_departure_ci95);
  EXPECT_LT(std::abs(ok.response.group_delay_s), 1.0);

  // 30 s inside: filled, not flagged.
  const mic::CalibrationWindow small = estimator.calibrate(without_rows(full, 1000, 30));
  EXPECT_EQ(small.estimate.quality, mic::Quality::kOk) << small.estimate.quality_text;
  EXPECT_EQ(small.interpolated, 30u);
  // 300 s inside (4.2 % of the window, under an hour): filled, not flagged, n still within
  // 4 standard errors of the truth.
  const mic::CalibrationWindow filled = estimator.calibrate(without_rows(full, 1000, 300));
  EXPECT_EQ(filled.estimate.quality, mic::Quality::kOk) << filled.estimate.quality_text;
  EXPECT_EQ(filled.interpolated, 300u);
  EXPECT_FALSE(filled.long_gap);
  const Eigen::Matrix3d z_filled =
      (filled.estimate.n - pair.n_true).cwiseAbs().array() / filled.estimate.n_stderr().array();
  EXPECT_LT(z_filled.maxCoeff(), 4.0) << z_filled;
  // Missing at the end (a silent topic), 400 s (5.6 %): counted although regularize_and_fill
  // trims it, and over the share.
  const mic::CalibrationWindow tail = estimator.calibrate(without_rows(full, 6800, 400));
  EXPECT_EQ(tail.trailing_missing, 400u);
  EXPECT_EQ(tail.estimate.quality, mic::Quality::kGaps);
  EXPECT_FALSE(tail.long_gap);
  // A user's max_fill of 60 s: a 120 s gap inside, 200 s missing at the end and 90 s at the
  // start each flag the window as a long gap.
  mic::WindowCalibrationSettings strict = plain_settings();
  strict.gaps.max_fill_s = 60.0;
  mic::WindowCalibrator strict_estimator(strict);
  const mic::CalibrationWindow long_gap = strict_estimator.calibrate(without_rows(full, 1000, 120));
  EXPECT_EQ(long_gap.estimate.quality, mic::Quality::kGaps);
  EXPECT_TRUE(long_gap.long_gap);
  EXPECT_NE(long_gap.estimate.quality_text.find("a gap longer than 60 s"), std::string::npos)
      << long_gap.estimate.quality_text;
  const mic::CalibrationWindow short_tail = strict_estimator.calibrate(without_rows(full, 7000, 200));
  EXPECT_EQ(short_tail.trailing_missing, 200u);
  EXPECT_EQ(short_tail.estimate.quality, mic::Quality::kGaps);
  EXPECT_EQ(estimator.calibrate(without_rows(full, 7000, 200)).estimate.quality, mic::Quality::kOk);
  const mic::CalibrationWindow head = strict_estimator.calibrate(without_rows(full, 0, 90));
  EXPECT_EQ(head.leading_missing, 90u);
  EXPECT_EQ(head.estimate.quality, mic::Quality::kGaps);
  // Many short gaps: more than 5 % interpolated.
  mic::WindowRecords holes = full;
  for (std::size_t g = 0; g < 20; ++g) holes = without_rows(holes, 100 + g * 300, 20);
  const mic::CalibrationWindow many = estimator.calibrate(holes);
  EXPECT_EQ(many.interpolated, 400u);
  EXPECT_EQ(many.estimate.quality, mic::Quality::kGaps) << many.estimate.quality_text;
}


namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();

struct HutWindow {
  mic::SimulatedPair pair;
  mic::HutTemperatureSettings hut;
  mic::WindowRecords window;
};

/// A 6 h simulated window at 1 Hz with the hut's temperature effect on the test, and the
/// thermometer channel as the window's temperature samples.
HutWindow hut_window(std::uint64_t seed) {
  HutWindow h;
  mic::test::HutPair hut = mic::test::hut_pair(seed, 21600.0);
  h.pair = std::move(hut.pair);
  h.hut = hut.hut;
  mic::WindowRecords& w = h.window;
  w.start_s = h.pair.reference.time_s.front();
  w.period_s = 1.0;
  w.expected_samples = h.pair.reference.size();
  w.paired.time_s = h.pair.reference.time_s;
  w.paired.reference_nT = h.pair.reference.values_nT;
  w.paired.test_nT = h.pair.test.values_nT;
  w.temperature.recorded = true;
  w.temperature.time_s = h.pair.test.time_s;
  w.temperature.value_C = h.pair.test.auxiliary.at(0).values;
  return h;
}

}  // namespace

TEST(WindowCalibration, HutTemperatureGivesTheApparentCoefficientsWithinTheirIntervals) {
  HutWindow h = hut_window(31);
  mic::WindowCalibrator estimator(without_noise_identification());
  const mic::CalibrationWindow r = estimator.calibrate(h.window);
  ASSERT_TRUE(r.temperature.fitted) << r.temperature.text;
  EXPECT_TRUE(r.temperature_known);
  EXPECT_EQ(r.temperature_samples, h.pair.reference.size());
  EXPECT_EQ(r.estimate.quality, mic::Quality::kOk) << r.estimate.quality_text;
  const Eigen::VectorXd theta = Eigen::Map<const Eigen::VectorXd>(h.pair.test.auxiliary[0].values.data(),
                                                                  static_cast<Eigen::Index>(h.pair.reference.size()));
  EXPECT_NEAR(r.temperature.reference_C, theta.mean(), 1e-9);
  for (int l = 0; l < 3; ++l) {
    // a = c + s F, F the window's mean field in the test frame.
    const double truth = h.hut.offset_nT_per_C(l) + 1e-6 * h.hut.scale_ppm_per_C(l) * h.pair.test.values_nT.col(l).mean();
    EXPECT_LT(std::abs(r.temperature.apparent_nT_per_C(l) - truth), r.temperature.apparent_ci95_nT_per_C(l))
        << "component " << l << ": " << r.temperature.apparent_nT_per_C(l) << " +- "
        << r.temperature.apparent_ci95_nT_per_C(l) << " vs " << truth;
  }
  // The same window without a temperature topic: estimated as before, the text says why.
  h.window.temperature = mic::TemperatureSamples{};
  const mic::CalibrationWindow without = estimator.calibrate(h.window);
  EXPECT_FALSE(without.temperature.fitted);
  EXPECT_EQ(without.temperature.text, "no sensor temperature: estimated without temperature terms");
  for (int l = 0; l < 3; ++l) EXPECT_LT(r.estimate.residual_rms_nT(l), without.estimate.residual_rms_nT(l)) << l;
}

TEST(WindowCalibration, MissingOrConstantTemperatureIsEstimatedWithoutTheTerms) {
  HutWindow h = hut_window(32);
  mic::WindowCalibrator estimator(without_noise_identification());
  mic::WindowRecords constant = h.window;
  for (double& v : constant.temperature.value_C) v = 21.5;
  const mic::CalibrationWindow c = estimator.calibrate(constant);
  EXPECT_FALSE(c.temperature.fitted);
  EXPECT_NE(c.temperature.text.find("temperature range 0 degC below 0.05 degC"), std::string::npos) << c.temperature.text;
  EXPECT_EQ(c.temperature.reference_C, 21.5);
  mic::WindowRecords empty = h.window;
  empty.temperature.time_s.clear();
  empty.temperature.value_C.clear();
  const mic::CalibrationWindow e = estimator.calibrate(empty);
  EXPECT_FALSE(e.temperature.fitted);
  EXPECT_EQ(e.temperature.text, "no temperature sample in the window: estimated without temperature terms");
  mic::WindowRecords gap = h.window;  // a 10 min hole in the thermometer (max gap 60 s)
  gap.temperature.time_s.erase(gap.temperature.time_s.begin() + 5000, gap.temperature.time_s.begin() + 5600);
  gap.temperature.value_C.erase(gap.temperature.value_C.begin() + 5000, gap.temperature.value_C.begin() + 5600);
  const mic::CalibrationWindow g = estimator.calibrate(gap);
  EXPECT_FALSE(g.temperature.fitted);
  EXPECT_FALSE(g.temperature_known);
  EXPECT_NE(g.temperature.text.find("NaN"), std::string::npos) << g.temperature.text;
  // All three: the estimate of the window without temperature terms.
  mic::WindowRecords plain = h.window;
  plain.temperature = mic::TemperatureSamples{};
  const mic::CalibrationWindow p = estimator.calibrate(plain);
  EXPECT_EQ(c.estimate.n, p.estimate.n);
  EXPECT_EQ(e.estimate.n, p.estimate.n);
  EXPECT_EQ(g.estimate.n, p.estimate.n);
}

namespace {

struct FilteredWindow {
  mic::SimulatedPair pair;
  mic::WindowRecords window;
};

/// A 12 h window at 1 Hz of the simulator's quiet pair (reference 3x quieter than the test, as a
/// certified reference beside a field instrument), the test behind corner_hz (0: none) and delay_s.
FilteredWindow filtered_window(std::uint64_t seed, double corner_hz, double delay_s) {
  mic::SimulationSettings s;
  s.seed = seed;
  s.duration_s = 43200.0;
  s.reference_white_nT = 0.0033;
  s.reference_pink_nT_per_sqrt_hz = 0.0017;
  FilteredWindow f;
  f.pair = mic::simulate_pair(s);
  mic::apply_test_response(f.pair.test.values_nT, s.sample_period_s, corner_hz, delay_s);
  mic::WindowRecords& w = f.window;
  w.start_s = f.pair.reference.time_s.front();
  w.period_s = s.sample_period_s;
  w.expected_samples = f.pair.reference.size();
  w.paired.time_s = f.pair.reference.time_s;
  w.paired.reference_nT = f.pair.reference.values_nT;
  w.paired.test_nT = f.pair.test.values_nT;
  return f;
}

/// Largest |scale-ratio error| over the three axes: in the estimate's own standard errors
/// (in_se) or as a fraction.
double worst_scale_error(const mic::WindowEstimate& e, const Eigen::Matrix3d& truth, bool in_se) {
  const mic::CalibrationParameters t = mic::decompose(truth);
  double worst = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double se = in_se ? e.parameters.scale_ratio_ci95(k) / e.parameters.interval_quantile : 1.0;
    worst = std::max(worst, std::abs(e.parameters.scale_ratio(k) - t.scale_ratio(k)) / se);
  }
  return worst;
}

}  // namespace

TEST(WindowResponseModel, EstimatesNThroughAFilteredTestAndShowsTheFilter) {
  // MIC_LIVE_RESPONSE_SEED: another seed (checked on 41-60 when written).
  const char* seed = std::getenv("MIC_LIVE_RESPONSE_SEED");
  const FilteredWindow f = filtered_window(seed != nullptr ? std::strtoull(seed, nullptr, 10) : 41, 0.03, 2.0);
  mic::WindowCalibrationSettings rule = without_noise_identification();
  ASSERT_TRUE(rule.response_model) << "the model is on by default (~response_model)";
  const mic::CalibrationWindow on = mic::WindowCalibrator(rule).calibrate(f.window);
  ASSERT_EQ(on.estimate.quality, mic::Quality::kOk) << on.estimate.quality_text;
  ASSERT_TRUE(on.response_model.applied) << on.response_model.text;
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(on.response_model.corner_hz(k), 0.03, 0.003) << "component " << k;
  }
  EXPECT_NEAR(on.response_model.delay_s, 2.0, 0.2);
  EXPECT_LT(worst_scale_error(on.estimate, f.pair.n_true, true), 3.5);

  rule.response_model = false;
  const mic::CalibrationWindow off = mic::WindowCalibrator(rule).calibrate(f.window);
  EXPECT_FALSE(off.response_model.fitted);
  EXPECT_TRUE(off.response_model.text.empty()) << off.response_model.text;
  // Without the model the filter's roll-off is taken for a loss of gain: several times the error.
  EXPECT_GT(worst_scale_error(off.estimate, f.pair.n_true, false),
            3.0 * worst_scale_error(on.estimate, f.pair.n_true, false));

  // The response reported is that of the test as recorded: the filter shows (gain 0.949 at 0.01 Hz).
  bool seen = false;
  for (const mic::ResponseBand& b : on.relative_response) {
    if (b.frequency_hz < 0.008 || b.frequency_hz > 0.012) continue;
    seen = true;
    const double truth = 1.0 / std::hypot(1.0, b.frequency_hz / 0.03);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(b.gain(k), truth, 0.02) << b.frequency_hz << " Hz, component " << k;
  }
  EXPECT_TRUE(seen);
}

TEST(WindowResponseModel, LeavesAMatchedPairAlone) {
  const FilteredWindow f = filtered_window(42, 0.0, 0.0);
  mic::WindowCalibrationSettings rule = without_noise_identification();
  const mic::CalibrationWindow on = mic::WindowCalibrator(rule).calibrate(f.window);
  rule.response_model = false;
  const mic::CalibrationWindow off = mic::WindowCalibrator(rule).calibrate(f.window);
  EXPECT_TRUE(on.response_model.fitted) << on.response_model.text;
  EXPECT_FALSE(on.response_model.applied) << on.response_model.text;
  EXPECT_EQ((on.estimate.n - off.estimate.n).cwiseAbs().maxCoeff(), 0.0);
}

TEST(WindowResponseModel, PlainEq2AsPrintedFitsNoModel) {
  // calibrate_records --method plain and ~method plain: Eq. 2 as printed, no modelled filter.
  const FilteredWindow f = filtered_window(43, 0.03, 2.0);
  const mic::CalibrationWindow r = mic::WindowCalibrator(plain_settings()).calibrate(f.window);
  EXPECT_FALSE(r.response_model.fitted);
  EXPECT_EQ(r.estimate.method, "plain");
  EXPECT_EQ(r.estimate.eiv, mic::ErrorsInVariables::kNotApplicable);
}

namespace {

/// One 12 h window at 1 Hz of three co-located instruments: reference white 0.1 nT (10x the
/// test's 0.01 nT: a noisy reference attenuates n), a second test of white 0.05 nT with its own
/// small misalignment; as the node's two channels hold them (reference paired with each test).
struct ThreeChannels {
  mic::SimulatedPair pair;
  mic::WindowRecords with_test, with_second;
};

ThreeChannels three_channels(std::uint64_t seed) {
  ThreeChannels t;
  mic::SimulationSettings s;
  s.seed = seed;
  s.duration_s = 43200.0;
  s.reference_white_nT = 0.1;
  s.test_white_nT = 0.01;
  s.reference_pink_nT_per_sqrt_hz = s.test_pink_nT_per_sqrt_hz = 0.0;
  s.keep_clean_field = true;
  t.pair = mic::simulate_pair(s);
  t.with_test.start_s = t.pair.reference.time_s.front();
  t.with_test.period_s = 1.0;
  t.with_test.expected_samples = t.pair.reference.time_s.size();
  t.with_test.paired.time_s = t.pair.reference.time_s;
  t.with_test.paired.reference_nT = t.pair.reference.values_nT;
  t.with_test.paired.test_nT = t.pair.test.values_nT;
  t.with_second = t.with_test;
  t.with_second.paired.test_nT =
      mic::co_located_instrument(t.pair.field_nT, mic::co_located_instrument_matrix(), 0.05, seed * 31 + 7);
  return t;
}

/// The identified noise on axis c as the white level (nT rms per sample at 1 s) of equal mean
/// PSD over [low, high] Hz: sqrt((2 w^2 + p^2 mean(1/f)) / 2).
double white_equivalent_nT(const mic::IdentifiedNoise& noise, int c, double low_hz, double high_hz) {
  const double inverse_f = std::log(high_hz / low_hz) / (high_hz - low_hz);
  const double psd = 2.0 * noise.white_nT(c) * noise.white_nT(c) +
                     inverse_f * noise.pink_nT_per_sqrt_hz(c) * noise.pink_nT_per_sqrt_hz(c);
  return std::sqrt(psd / 2.0);
}

}  // namespace

namespace {

/// `window` with `other`'s test samples of the same epochs as its third instrument, named test 'b'.
mic::WindowRecords with_third(mic::WindowRecords window, const mic::WindowRecords& other) {
  auto third = std::make_shared<mic::VectorRecord>();
  third->time_s = other.paired.time_s;
  third->values_nT = other.paired.test_nT;
  window.third = std::move(third);
  window.third_name = "test 'b'";
  return window;
}

}  // namespace

TEST(WindowWithHat, IdentifiesTheReferenceNoiseAndCorrectsWithIt) {
  const ThreeChannels t = three_channels(61);
  mic::WindowCalibrator estimator{mic::WindowCalibrationSettings{}};
  const mic::CalibrationWindow r = estimator.calibrate(with_third(t.with_test, t.with_second));
  const mic::IdentifiedNoise& noise = r.reference_noise;
  ASSERT_TRUE(noise.identified) << noise.text;
  EXPECT_EQ(r.estimate.eiv, mic::ErrorsInVariables::kApplied);
  EXPECT_EQ(r.estimate.eiv_noise.source, mic::NoiseSource::kThreeCorneredHat);
  EXPECT_NE(r.estimate.eiv_text().find("three-cornered hat with test 'b'"), std::string::npos) << r.estimate.eiv_text();
  // The identified level (ASD over the band) against the simulated white 0.1 nT: within 20 %.
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(white_equivalent_nT(noise, c, 0.0002, 0.01) / 0.1, 1.0, 0.2) << c << ": " << noise.text;
  // The window's estimate is the estimator's with that noise as its input (the same settings
  // otherwise; the matched pair's response model applies no filter).
  ASSERT_FALSE(r.response_model.applied);
  mic::WindowInputs given;
  given.reference_noise = noise.model(mic::NoiseSource::kThreeCorneredHat, "test 'b'");
  const mic::WindowEstimate direct = mic::WindowEstimator(mic::EstimatorSettings{})
                                         .estimate(t.with_test.paired.reference_nT, t.with_test.paired.test_nT, 1.0, given);
  EXPECT_EQ(r.estimate.n, direct.n);
  // The correction moves n off the uncorrected estimate, upwards (attenuation removed): the
  // corrected scale ratios exceed the uncorrected ones on every axis.
  const mic::CalibrationWindow uncorrected =
      mic::WindowCalibrator(without_noise_identification()).calibrate(t.with_test);
  for (int c = 0; c < 3; ++c) {
    EXPECT_GT(r.estimate.parameters.scale_ratio(c), uncorrected.estimate.parameters.scale_ratio(c)) << c;
  }
}

TEST(WindowWithHat, WithoutAThirdOrWithTheSameRecordTwiceTheHatCorrectsNothing) {
  // With the pair's own noise off, nothing else can correct: a window without a third, or whose
  // "third" is the test record again (a copied topic: shared noise), keeps the uncorrected n.
  const ThreeChannels t = three_channels(62);
  mic::WindowCalibrator estimator(without_noise_identification(true));
  const mic::CalibrationWindow alone = estimator.calibrate(t.with_test);
  EXPECT_FALSE(alone.reference_noise.identified);
  EXPECT_EQ(alone.estimate.eiv, mic::ErrorsInVariables::kNoNoiseModel);
  const mic::CalibrationWindow copy = estimator.calibrate(with_third(t.with_test, t.with_test));
  EXPECT_FALSE(copy.reference_noise.identified);
  EXPECT_NE(copy.reference_noise.text.find("one record twice"), std::string::npos) << copy.reference_noise.text;
  EXPECT_EQ(copy.estimate.n, alone.estimate.n);
  // With the pair's noise on (the default), a failed hat falls back to it.
  const mic::CalibrationWindow fallback = mic::WindowCalibrator{mic::WindowCalibrationSettings{}}.calibrate(
      with_third(t.with_test, t.with_test));
  EXPECT_EQ(fallback.estimate.eiv_noise.source, mic::NoiseSource::kPairAboveBand) << fallback.reference_noise.text;
}

TEST(WindowCalibration, SpikesMoveNLittleWithTheScreenAndLessDespiked) {
  // 50 nT one-sample spikes in both records of a 12 h window, reference noise 0.1 nT. Left to
  // the robust screen, whose masked runs are filled through local means, n moves by under half
  // a standard error (1.3 with the line through two neighbours it used before:
  // test_fill_masked). Despiked first (as calibrate_records and calibration_node's
  // StreamingDespiker do to each record at its own rate), n moves by a small fraction of one, and
  // the 20 spikes are found.
  const ThreeChannels t = three_channels(63);
  mic::WindowRecords spiky = t.with_test;
  for (int k = 0; k < 10; ++k) {
    spiky.paired.reference_nT(1000 + 4000 * k, k % 3) += 50.0;
    spiky.paired.test_nT(3000 + 4000 * k, (k + 1) % 3) -= 50.0;
  }
  mic::WindowCalibrator estimator(without_noise_identification());
  const mic::CalibrationWindow clean = estimator.calibrate(t.with_test);
  mic::WindowRecords despiked_records = spiky;
  const std::size_t spikes = mic::despike(despiked_records.paired.reference_nT, mic::DespikeSettings{}) +
                             mic::despike(despiked_records.paired.test_nT, mic::DespikeSettings{});
  EXPECT_EQ(spikes, 20u);
  const mic::CalibrationWindow despiked = estimator.calibrate(despiked_records);
  EXPECT_EQ(despiked.interpolated, 20u);  // each spike's epoch, filled in both records
  const Eigen::Matrix3d se = despiked.estimate.n_stderr();
  const double moved = ((despiked.estimate.n - clean.estimate.n).cwiseAbs().array() / se.array()).maxCoeff();
  const mic::CalibrationWindow screened = estimator.calibrate(spiky);
  const double moved_screened = ((screened.estimate.n - clean.estimate.n).cwiseAbs().array() / se.array()).maxCoeff();
  std::printf("largest move of n by the spikes / se: despiked %.3f, screened only %.3f\n", moved, moved_screened);
  EXPECT_LT(moved, 0.2);
  EXPECT_LT(moved_screened, 0.8);
}

TEST(WindowWithPairNoise, IdentifiesTheReferenceNoiseFromOneTestAndCorrectsWithIt) {
  // One test instrument: the reference's noise (white 0.1 nT, 10x the test's) from the window's
  // pair above the band, then the window estimated again with it as its input.
  const ThreeChannels t = three_channels(63);
  const mic::CalibrationWindow r = mic::WindowCalibrator{mic::WindowCalibrationSettings{}}.calibrate(t.with_test);
  const mic::IdentifiedNoise& noise = r.reference_noise;
  ASSERT_TRUE(noise.identified) << noise.text;
  EXPECT_EQ(r.estimate.eiv_noise.source, mic::NoiseSource::kPairAboveBand);
  EXPECT_NE(r.estimate.eiv_text().find("from the pair above the band"), std::string::npos) << r.estimate.eiv_text();
  // The white level against the simulated 0.1 nT: within 10 % (97-100 pT). The PSD at the top
  // half of the band (0.005-0.01 Hz, where the field is weakest and the correction matters)
  // against the simulated 2 x 0.1^2 nT^2/Hz, in units of its own stated standard deviation (the
  // levels' covariance, which n's intervals carry): within 3.5. The fit also finds a few
  // pT/sqrt(Hz) of 1/f noise that is not there, which extrapolated 3-6x below its lowest bin
  // adds 0-50 % (median 1 %, 95th percentile 53 % over 200 held-out 12-hour windows, seeds
  // 7100-7299; this seed: 25 %, 0.7 standard deviations), and that uncertainty is stated: z has
  // a median of 0.02, a 95th percentile of 1.5 and a largest value of 3.0 over those windows.
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(noise.white_nT(c) / 0.1, 1.0, 0.1) << c << ": " << noise.text;
    const double inverse_f = std::log(0.01 / 0.005) / 0.005;  // mean 1/f over 0.005-0.01 Hz
    const Eigen::Vector2d gradient(2.0, inverse_f);           // d PSD / d (w^2, p^2), dt = 1 s
    const double psd = 2.0 * std::pow(white_equivalent_nT(noise, c, 0.005, 0.01), 2);
    const double sd = std::sqrt(gradient.dot(noise.level_covariance[static_cast<std::size_t>(c)] * gradient));
    ASSERT_GT(sd, 0.0) << c;
    std::printf("axis %d: 0.005-0.01 Hz level / truth %.3f, PSD error / its sd %.2f\n", c,
                white_equivalent_nT(noise, c, 0.005, 0.01) / 0.1, (psd - 2.0 * 0.1 * 0.1) / sd);
    EXPECT_LT(std::abs(psd - 2.0 * 0.1 * 0.1) / sd, 3.5) << c << ": " << noise.text << ", sd " << sd;
  }
  // The window's estimate is the estimator's with that noise as its input (the same settings
  // otherwise; the matched pair's response model applies no filter).
  ASSERT_FALSE(r.response_model.applied);
  mic::WindowInputs given;
  given.reference_noise = noise.model(mic::NoiseSource::kPairAboveBand, "");
  const mic::WindowEstimate expected = mic::WindowEstimator(mic::EstimatorSettings{})
                                           .estimate(t.with_test.paired.reference_nT, t.with_test.paired.test_nT, 1.0, given);
  EXPECT_EQ(r.estimate.n, expected.n);
}
