// Monte Carlo of the DEFAULT estimator and plain Eq. 2 on the SAME simulated records, with
// disturbances the estimators do not model (unmodelled_disturbances.hpp: test-pier tilt random
// walk, heater cycling in the test sensor, filter/delay mismatch of the test instrument) on top
// of traffic seen with different gains and directions, spikes, gaps and a weak vertical. A
// program, not a test (minutes of run time); figures in docs/validation.md and docs/accuracy.md.
//
//   monte_carlo_unmodelled disturbed [seeds=50] [days=5] [first_seed=1000]
//   monte_carlo_unmodelled quiet     [seeds=100] [days=2] [first_seed=1000]
//   monte_carlo_unmodelled filter    [seeds=100] [days=2] [first_seed=1000]  the quiet station,
//                                    test behind a 1-pole low-pass MC_CORNER (0.03 Hz) and a
//                                    delay MC_DELAY (2 s), nothing else
//   monte_carlo_unmodelled hat       [seeds=200] [days=1] [first_seed=7000]  three instruments,
//                                    reference noise identified by the three-cornered hat
//   monte_carlo_unmodelled wic       [data_dir=data]   four 6-hour quarters + the whole day: the
//                                    default, plain Eq. 2, the default without the pair's noise
//                                    (MC_WIC_NOISE_PT: reference noise figure for the default, as 1/f
//                                    at 1 Hz; MC_WIC_WHITE_PT: the same read as a flat ASD)
//
// Printed per estimator: median and 95th percentile over the seeds of the largest |scale-ratio
// error| of the three axes (%) and of the largest |non-orthogonality error| (deg), and the
// share of the six parameters
// (3 scale ratios, 3 non-orthogonalities) inside their 95 % intervals. Per-seed lines start
// with "seed". Environment knobs (MC_*) change one disturbance at a time; see scenario() in
// unmodelled_scenario.hpp.
// MC_METHODS (default "default,plain") lists the estimators, each on the same records: default
// (the package's defaults), plain (Eq. 2 alone), none (the robust estimator alone, EIV correction
// off), given (the robust estimator alone, the simulated reference noise given as the window's
// noise model, as a maker's figure), nomodel (the robust estimator alone with the default
// settings: no response model, and no noise model so no EIV correction), givenmodel (the default
// pipeline with the simulated reference noise as the reference's noise figure), hat (the default
// pipeline with a third instrument, as calibrate_records --third: the three-cornered hat in the
// window; a quiet third sensor of the test's noise class with its own misalignment, on a pier
// without the test's tilt, heater and traffic view), nopair (the default pipeline without the
// reference's noise from the pair, --no-pair-noise: no EIV correction without a figure or a
// third).
// MC_PRINT_MODEL=1 adds, after each pipeline line, the window's response model and its
// reference-noise line ("#   ...").
#include "bias_scatter.hpp"
#include "unmodelled_scenario.hpp"
#include "window_agreement.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "magnetometer_insitu_calibration/estimation/robust/robust_estimator.hpp"
#include "magnetometer_insitu_calibration/estimation/three_cornered_hat.hpp"
#include "magnetometer_insitu_calibration/pipeline/reference_noise.hpp"
#include "magnetometer_insitu_calibration/estimation/calibration_matrix.hpp"
#include "magnetometer_insitu_calibration/simulation/co_located_instrument.hpp"
#include "magnetometer_insitu_calibration/simulation/power_law_noise.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "magnetometer_insitu_calibration/simulation/station_disturbances.hpp"
#include "magnetometer_insitu_calibration/simulation/unmodelled_disturbances.hpp"
#include "magnetometer_insitu_calibration/preprocessing/gap_filling.hpp"

#include "percentile.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

using monte_carlo::knob;


struct Tally {
  std::vector<double> scale_pct, angle_deg;
  int covered = 0, checked = 0;
  // The same intervals with the normal quantile 1.96 instead of the window's Student t, to
  // compare the two on the same records.
  int covered_normal = 0;
  std::vector<double> quantile;  // each window's half-width in standard errors
  // Per parameter (scale x, y, z; non-orthogonality xy, xz, yz): inside its interval, and the
  // error in standard errors (ci95 / interval_quantile), to tell a biased parameter from a wide
  // scatter.
  Eigen::Matrix<double, 6, 1> inside = Eigen::Matrix<double, 6, 1>::Zero(), z_sum = inside, z2_sum = inside;
  void add(const mic::WindowEstimate& e, const Eigen::Matrix3d& truth, int (&cov)[6]) {
    const mic::CalibrationParameters t = mic::decompose(truth);
    const mic::CalibrationParameters& q = e.parameters;
    double worst_scale = 0.0, worst_angle = 0.0;
    for (int l = 0; l < 3; ++l) {
      const double ds = q.scale_ratio(l) - t.scale_ratio(l);
      const double da = q.nonorthogonality_deg(l) - t.nonorthogonality_deg(l);
      worst_scale = std::max(worst_scale, 100.0 * std::abs(ds));
      worst_angle = std::max(worst_angle, std::abs(da));
      cov[l] = std::abs(ds) <= q.scale_ratio_ci95(l);
      cov[3 + l] = std::abs(da) <= q.nonorthogonality_ci95_deg(l);
      const double se[2] = {q.scale_ratio_ci95(l) / q.interval_quantile,
                            q.nonorthogonality_ci95_deg(l) / q.interval_quantile};
      const double z[2] = {ds / se[0], da / se[1]};
      covered_normal += (std::abs(z[0]) <= mic::kNormalQuantile95) + (std::abs(z[1]) <= mic::kNormalQuantile95);
      for (int k = 0; k < 2; ++k) {
        inside(3 * k + l) += cov[3 * k + l];
        z_sum(3 * k + l) += z[k];
        z2_sum(3 * k + l) += z[k] * z[k];
      }
      covered += cov[l] + cov[3 + l];
      checked += 2;
    }
    scale_pct.push_back(worst_scale);
    angle_deg.push_back(worst_angle);
    quantile.push_back(q.interval_quantile);
  }
};

/// MC_METHODS as a list of estimator names (default "default,plain"); throws for an unknown one.
std::vector<std::string> listed_methods() {
  const char* text = std::getenv("MC_METHODS");
  const std::string list = text != nullptr ? text : "default,plain";
  std::vector<std::string> names;
  std::string item;
  for (std::size_t at = 0; at <= list.size(); ++at) {
    if (at == list.size() || list[at] == ',') {
      if (item != "default" && item != "plain" && item != "none" && item != "given" && item != "nomodel" &&
          item != "givenmodel" && item != "hat" && item != "nopair")
        throw std::runtime_error("MC_METHODS: unknown estimator '" + item + "'");
      names.push_back(item);
      item.clear();
    } else {
      item += list[at];
    }
  }
  return names;
}

/// The third instrument of the "hat" method: B n_c + white + 1/f noise of the simulator's
/// defaults, its own random streams.
mic::VectorRecord simulated_third(const mic::SimulatedPair& pair, const mic::SimulationSettings& s, std::uint64_t seed) {
  const Eigen::Matrix3d n_c = mic::co_located_instrument_matrix();
  const std::size_t n = static_cast<std::size_t>(pair.field_nT.rows());
  mic::VectorRecord third;
  third.time_s = pair.reference.time_s;
  third.values_nT = pair.field_nT * n_c;
  mic::SimulationRng rng(seed, 9001);
  mic::SpectralSynthesizer synth(n);
  const mic::SimulationSettings defaults;
  for (int c = 0; c < 3; ++c) {
    const Eigen::VectorXcd pink = mic::power_law_spectrum(n, s.sample_period_s, 1.0, 0.0,
        defaults.test_pink_nT_per_sqrt_hz * defaults.test_pink_nT_per_sqrt_hz, rng);
    third.values_nT.col(c) += synth.synthesize(pink, s.sample_period_s) / static_cast<double>(n);
    for (std::size_t i = 0; i < n; ++i) third.values_nT(static_cast<Eigen::Index>(i), c) += defaults.test_white_nT * rng.normal();
  }
  return third;
}

/// One seed's records, shared by every estimator of MC_METHODS.
struct SeedRecords {
  mic::SimulationSettings simulation;
  mic::SimulatedPair pair;
  mic::PreparedPair prepared;  ///< on the estimation grid, NaN = missing (the pipeline's input)
  mic::PreparedPair filled;    ///< the same with its gaps filled (the estimators alone take it)
  mic::VectorRecord third;     ///< the "hat" method's third instrument (empty without it)
};

/// One estimator's whole-record window: its estimate, and for a pipeline method the window's
/// response model and reference-noise lines.
struct MethodResult {
  mic::WindowEstimate estimate;
  std::string model_text, noise_text;
};

MethodResult estimate_method(const std::string& name, const SeedRecords& r, const mic::CalibrationSettings& base) {
  mic::EstimatorSettings es = base.window.estimator;
  // Robust-step knobs, to find which step costs what (defaults: the package's).
  es.robust.screen = knob("MC_SCREEN", 1.0) != 0.0;
  es.robust.huber_k = knob("MC_HUBER_K", es.robust.huber_k);
  es.robust.section_s = knob("MC_SECTION_S", es.robust.section_s);
  es.robust.section_trend = knob("MC_SECTION_TREND", 1.0) != 0.0;
  es.robust.section_rejection = knob("MC_SECTION_REJECTION", es.robust.section_rejection);
  es.robust.correct_delay = knob("MC_CORRECT_DELAY", 1.0) != 0.0;
  es.band_low_hz = knob("MC_BAND_LOW", es.band_low_hz);
  mic::NoiseSpectrum simulated;  // the simulated reference noise, as a maker's figure
  simulated.white_nT.setConstant(r.simulation.reference_white_nT);
  simulated.pink_nT_per_sqrt_hz.setConstant(r.simulation.reference_pink_nT_per_sqrt_hz);
  MethodResult out;
  if (name == "default" || name == "nopair" || name == "givenmodel" || name == "hat") {
    // The default pipeline: robust estimator, response model, the reference's noise.
    mic::CalibrationSettings cs = base;
    cs.window.estimator.robust = es.robust;  // the knobs above
    cs.window.estimator.band_low_hz = es.band_low_hz;
    if (name == "nopair") cs.window.pair_noise = false;  // no EIV correction without a figure or a third
    if (name == "givenmodel") cs.window.reference_noise_figure = simulated;
    const mic::CalibrationWindow w =
        name == "hat" ? mic::calibrate_records(r.pair.reference, r.pair.test, cs, {&r.third}).windows.back()
                      : mic::calibrate_prepared(r.prepared, cs).back();
    out.estimate = w.estimate;
    out.model_text = w.response_model.text;
    out.noise_text = w.reference_noise.text;
    return out;
  }
  // The estimators alone: plain Eq. 2, or the robust estimator (nomodel: with the default settings).
  if (name == "plain") es.method = mic::EstimatorMethod::kPlain;
  if (name == "none" || name == "given") es.method = mic::EstimatorMethod::kRobust;
  if (name == "none") es.robust.errors_in_variables = false;
  mic::WindowInputs inputs;
  if (name == "given") inputs.reference_noise = mic::ReferenceNoiseModel::maker_figure(simulated);
  mic::WindowEstimator estimator(es);
  out.estimate = estimator.estimate(r.filled.paired.reference_nT, r.filled.paired.test_nT, r.filled.sample_period_s,
                                    inputs);
  return out;
}

int run_simulated(const std::string& kind, int seeds, double days, std::uint64_t first_seed) {
  const std::vector<std::string> names = listed_methods();
  const int methods = static_cast<int>(names.size());
  const bool with_third = std::find(names.begin(), names.end(), "hat") != names.end();  // needs the clean field
  std::printf("# %s station: seeds %llu-%llu, %.1f days at 1 Hz, whole record as one window\n", kind.c_str(),
              static_cast<unsigned long long>(first_seed), static_cast<unsigned long long>(first_seed + seeds - 1), days);
  std::printf("# seed method dscale_x%% dscale_y%% dscale_z%% dnonorth_xy dnonorth_xz dnonorth_yz deg covered(6) eiv\n");
  std::vector<Tally> tally(static_cast<std::size_t>(methods));
  const mic::CalibrationSettings base;
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k < seeds; ++k) {
    const std::uint64_t seed = first_seed + static_cast<std::uint64_t>(k);
    SeedRecords r;
    r.pair = monte_carlo::station_records(kind, seed, days, with_third, &r.simulation);
    r.prepared = mic::prepare_pair(r.pair.reference, r.pair.test, base.preprocess);
    r.filled = r.prepared;
    mic::fill_gaps(r.filled.paired, r.filled.sample_period_s, base.window.gaps);
    if (with_third) r.third = simulated_third(r.pair, r.simulation, seed);
    for (int m = 0; m < methods; ++m) {
      const std::string& name = names[static_cast<std::size_t>(m)];
      const MethodResult result = estimate_method(name, r, base);
      const mic::WindowEstimate& e = result.estimate;
      int cov[6];
      tally[static_cast<std::size_t>(m)].add(e, r.pair.n_true, cov);
      const mic::CalibrationParameters t = mic::decompose(r.pair.n_true);
      const Eigen::Vector3d ds = 100.0 * (e.parameters.scale_ratio - t.scale_ratio);
      const Eigen::Vector3d da = e.parameters.nonorthogonality_deg - t.nonorthogonality_deg;
      std::printf("seed %llu %s %.4f %.4f %.4f %.4f %.4f %.4f %d %s\n", static_cast<unsigned long long>(seed), name.c_str(), ds(0),
                  ds(1), ds(2), da(0), da(1), da(2), cov[0] + cov[1] + cov[2] + cov[3] + cov[4] + cov[5],
                  name == "plain" ? "-" : (e.eiv == mic::ErrorsInVariables::kApplied ? "applied" : "none"));
      const bool print_model = std::getenv("MC_PRINT_MODEL") != nullptr;
      if (!result.model_text.empty() && print_model) std::printf("#   %s\n", result.model_text.c_str());
      if (!result.noise_text.empty() && print_model) std::printf("#   %s\n", result.noise_text.c_str());
    }
    std::fflush(stdout);
  }
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("\n| estimator | max scale error median / 95th pct | max non-orthogonality error median / 95th pct "
              "| 6 parameters inside 95 %% interval | the same with 1.96 se | half-width in se, median (5th-95th "
              "pct) |\n|---|---|---|---|---|---|\n");
  for (int m = 0; m < methods; ++m) {
    const Tally& t = tally[static_cast<std::size_t>(m)];
    std::printf("| %s | %.3f / %.3f %% | %.3f / %.3f deg | %.1f %% | %.1f %% | %.3f (%.3f-%.3f) |\n",
                names[static_cast<std::size_t>(m)].c_str(), percentile(t.scale_pct, 0.5), percentile(t.scale_pct, 0.95),
                percentile(t.angle_deg, 0.5), percentile(t.angle_deg, 0.95), 100.0 * t.covered / std::max(1, t.checked),
                100.0 * t.covered_normal / std::max(1, t.checked), percentile(t.quantile, 0.5),
                percentile(t.quantile, 0.05), percentile(t.quantile, 0.95));
  }
  for (int m = 0; m < methods; ++m) {
    const Tally& t = tally[static_cast<std::size_t>(m)];
    const double count = static_cast<double>(t.scale_pct.size());
    std::printf("# %s per parameter (scale x y z, non-orth xy xz yz): inside %%", names[static_cast<std::size_t>(m)].c_str());
    for (int k = 0; k < 6; ++k) std::printf(" %.0f", 100.0 * t.inside(k) / count);
    std::printf("; mean z");
    for (int k = 0; k < 6; ++k) std::printf(" %+.2f", t.z_sum(k) / count);
    std::printf("; rms z");
    for (int k = 0; k < 6; ++k) std::printf(" %.2f", std::sqrt(t.z2_sum(k) / count));
    std::printf("\n");
  }
  std::printf("# %.0f s for %d seeds\n", elapsed, seeds);
  return 0;
}

/// Real pair: per parameter, sqrt(chi2 / 3) of the four quarters around their weighted mean
/// (standard errors = ci95 / 1.96), and the whole day's scale ratios with their half-widths.
/// The whole day's reference-noise bins from the pair (estimate +- its standard deviation, per
/// axis, pT/sqrt(Hz) as the ASD of each bin's mean PSD) against what the maker's figure, 10
/// pT/sqrt(Hz), predicts there read as 1/f at 1 Hz and read as a flat level, and each reading's
/// excess in standard deviations: the data's test of the figure where the pair can measure the
/// reference's noise.
void print_pair_bins_against_figure(const mic::VectorRecord& reference, const mic::VectorRecord& test,
                                    const mic::CalibrationSettings& settings, const mic::CalibrationWindow& day) {
  // The record with its gaps filled, as the per-window stage fills the day's window.
  mic::PreparedPair prepared = mic::prepare_pair(reference, test, settings.preprocess);
  mic::fill_gaps(prepared.paired, prepared.sample_period_s, settings.window.gaps);
  const mic::IdentifiedNoise noise = mic::identify_reference_noise_from_pair(
      prepared.paired.reference_nT, prepared.paired.test_nT, prepared.sample_period_s, day.estimate, day.response_model,
      settings.window.estimator.band_high_hz);
  std::printf("# the day's pair bins, reference ASD x, y, z in pT/sqrt(Hz) (+- 1 sd); 10 pT/sqrt(Hz) read as 1/f at 1 Hz "
              "and as flat: (prediction - estimate) / sd per axis\n");
  const double figure = 0.010;  // nT/sqrt(Hz)
  for (std::size_t k = 0; k < noise.pair.reference_psd.size(); ++k) {
    const double lo = noise.pair.bin_low_hz[k], hi = noise.pair.bin_high_hz[k];
    const double as_pink = figure * figure * std::log(hi / lo) / (hi - lo), as_flat = figure * figure;  // nT^2/Hz
    const Eigen::Vector3d& psd = noise.pair.reference_psd[k];
    const Eigen::Vector3d& sd = noise.pair.reference_psd_sd[k];
    const auto asd = [](double v) { return 1e3 * std::sqrt(std::max(v, 0.0)); };
    std::printf("#   %.4f-%.4f Hz: %.1f (%.1f-%.1f), %.1f (%.1f-%.1f), %.1f (%.1f-%.1f); 1/f %.1f: %+.1f %+.1f %+.1f sd; flat %.1f: "
                "%+.1f %+.1f %+.1f sd\n",
                lo, hi, asd(psd(0)), asd(psd(0) - sd(0)), asd(psd(0) + sd(0)), asd(psd(1)), asd(psd(1) - sd(1)),
                asd(psd(1) + sd(1)), asd(psd(2)), asd(psd(2) - sd(2)), asd(psd(2) + sd(2)), asd(as_pink),
                (as_pink - psd(0)) / sd(0), (as_pink - psd(1)) / sd(1), (as_pink - psd(2)) / sd(2), asd(as_flat),
                (as_flat - psd(0)) / sd(0), (as_flat - psd(1)) / sd(1), (as_flat - psd(2)) / sd(2));
  }
}

int run_wic(const std::string& dir) {
  const mic::VectorRecord reference = mic::read_record(dir + "/wic20250514_lemi036.sec.gz");
  const mic::VectorRecord test = mic::read_record(dir + "/wic20250514_fge.sec.gz");
  std::printf("| estimator | sqrt(chi2/dof) of the quarters: scale H, E, Z; non-orth HE, HZ, EZ | whole day scale H, E, Z (95 %%) | EIV |\n|---|---|---|---|\n");
  // m: 0 the default, 1 plain Eq. 2, 2 the default without the pair's noise (no EIV correction
  // without a figure).
  for (int m = 0; m < 3; ++m) {
    mic::CalibrationSettings settings;
    if (m == 2) settings.window.pair_noise = false;
    settings.windows.intervals = 4;
    if (m == 1) settings.window.estimator.method = mic::EstimatorMethod::kPlain;
    // MC_WIC_NOISE_PT: the reference's noise figure (pT/sqrt(Hz) at 1 Hz) for the default.
    settings.window.reference_noise_figure.pink_nT_per_sqrt_hz.setConstant(knob("MC_WIC_NOISE_PT", 0.0) / 1000.0);
    // MC_WIC_WHITE_PT: the same figure read as a flat (white) ASD, pT/sqrt(Hz): rms per sample
    // ASD sqrt(1 / (2 dt)) at dt = 1 s.
    settings.window.reference_noise_figure.white_nT.setConstant(knob("MC_WIC_WHITE_PT", 0.0) / 1000.0 / std::sqrt(2.0));
    const mic::PairCalibration result = mic::calibrate_records(reference, test, settings);
    const std::array<double, 6> chi = monte_carlo::quarters_scatter(result.windows);
    const auto& day = result.windows.back().estimate;
    const auto& q = day.parameters;
    std::printf("| %s | %.2f, %.2f, %.2f; %.2f, %.2f, %.2f | %.5f+-%.5f, %.5f+-%.5f, %.5f+-%.5f | %s |\n",
                m == 0 ? "default" : (m == 1 ? "plain Eq. 2" : "default without the pair's noise"), chi[0], chi[1], chi[2],
                chi[3], chi[4], chi[5], q.scale_ratio(0), q.scale_ratio_ci95(0), q.scale_ratio(1), q.scale_ratio_ci95(1),
                q.scale_ratio(2), q.scale_ratio_ci95(2), day.eiv_text().c_str());
    for (const auto& w : result.windows)
      if (!w.reference_noise.text.empty()) std::printf("#   %s: %s\n", w.label.c_str(), w.reference_noise.text.c_str());
    if (m == 2) print_pair_bins_against_figure(reference, test, settings, result.windows.back());
  }
  return 0;
}

/// Three instruments on one node: reference (white 0.1 nT, x10 the test's), test (0.01 nT) and
/// a second test (0.05 nT, independent noise). The reference's noise is identified by the
/// three-cornered hat as calibrate_records --third does in each window (identify_reference_noise:
/// cross-spectral, bins over the band and above it, white + 1/f fit) and given to the robust
/// estimator's EIV correction as the window's measured input (WindowInputs). Printed: identified /
/// true noise level per axis (mean over seeds), and the z, x, y scale-ratio bias in units of its
/// scatter (the "bias below 0.2 standard errors" aim).
int run_hat(int seeds, double days, std::uint64_t first_seed) {
  std::vector<Eigen::Vector3d> err[2], level;
  for (int k = 0; k < seeds; ++k) {
    mic::SimulationSettings s;
    s.seed = first_seed + static_cast<std::uint64_t>(k);
    s.duration_s = days * 86400.0;
    s.reference_white_nT = 0.1;
    s.test_white_nT = 0.01;
    s.reference_pink_nT_per_sqrt_hz = s.test_pink_nT_per_sqrt_hz = 0.0;
    s.keep_clean_field = true;
    const mic::SimulatedPair pair = mic::simulate_pair(s);
    mic::VectorRecord third;
    third.time_s = pair.reference.time_s;
    third.values_nT =
        mic::co_located_instrument(pair.field_nT, mic::co_located_instrument_matrix(), 0.05, s.seed * 31 + 7);
    // As calibrate_records --third does it (reference_noise.hpp): the pair and the third on the
    // estimation epochs, the hat over the band and above it, the reference's bins fitted by
    // white + 1/f noise.
    const mic::EstimatorSettings defaults;
    const mic::PreparedPair with_test = mic::prepare_pair(pair.reference, pair.test, mic::PreprocessSettings{});
    const mic::PreparedSides sides = mic::prepare_sides(pair.reference, with_test, {&third}, mic::CalibrationSettings{});
    const double whole = std::numeric_limits<double>::infinity();
    const mic::IdentifiedNoise noise =
        mic::identify_reference_noise(with_test.paired, sides.third->on_epochs(-whole, whole), with_test.sample_period_s,
                                      defaults.band_low_hz, defaults.band_high_hz);
    const Eigen::Vector3d& white = noise.white_nT;
    const Eigen::Vector3d& pink = noise.pink_nT_per_sqrt_hz;
    // Level: the ASD of the fitted noise over the band against the simulated white level.
    const double band_low = defaults.band_low_hz, band_high = defaults.band_high_hz;
    const double inverse_f = std::log(band_high / band_low) / (band_high - band_low);
    const Eigen::Vector3d fitted_psd = 2.0 * s.sample_period_s * white.cwiseAbs2() + inverse_f * pink.cwiseAbs2();
    level.push_back((fitted_psd / (2.0 * s.sample_period_s)).cwiseSqrt() / s.reference_white_nT);
    const Eigen::Vector3d truth = mic::decompose(pair.n_true).scale_ratio;
    for (int m = 0; m < 2; ++m) {
      // m == 1: identified (with its levels' covariance, as the CLI gives it); m == 0: not identified
      mic::WindowInputs inputs;
      if (m == 1) inputs.reference_noise = noise.model(mic::NoiseSource::kThreeCorneredHat, "--third");
      mic::WindowEstimator estimator(defaults);
      const mic::WindowEstimate e =
          estimator.estimate(pair.reference.values_nT, pair.test.values_nT, s.sample_period_s, inputs);
      err[m].push_back(e.parameters.scale_ratio - truth);
    }
    std::printf("seed %llu level %.3f %.3f %.3f\n", static_cast<unsigned long long>(s.seed), level.back()(0),
                level.back()(1), level.back()(2));
    std::fflush(stdout);
  }
  Eigen::Vector3d mean_level = Eigen::Vector3d::Zero();
  for (const auto& l : level) mean_level += l / static_cast<double>(seeds);
  std::printf("# identified / true reference noise level x, y, z: %.3f %.3f %.3f\n", mean_level(0), mean_level(1), mean_level(2));
  for (int m = 0; m < 2; ++m) {
    const Eigen::Vector3d z = monte_carlo::bias_over_scatter(err[m]);
    std::printf("| %s | %.2f, %.2f, %.2f |\n", m == 0 ? "default, noise not identified" : "default, reference noise from the hat",
                z(0), z(1), z(2));
  }
  std::printf("# bias / scatter of the scale ratios x, y, z; its own standard error 1 / sqrt(%d)\n", seeds);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "disturbed";
  try {
    if (mode == "disturbed" || mode == "quiet" || mode == "filter") {
      const bool quiet = mode != "disturbed";
      return run_simulated(mode, argc > 2 ? std::atoi(argv[2]) : (quiet ? 100 : 50),
                           argc > 3 ? std::atof(argv[3]) : (quiet ? 2.0 : 5.0),
                           argc > 4 ? std::strtoull(argv[4], nullptr, 10) : 1000);
    }
    if (mode == "wic") return run_wic(argc > 2 ? argv[2] : "data");
    if (mode == "hat")
      return run_hat(argc > 2 ? std::atoi(argv[2]) : 200, argc > 3 ? std::atof(argv[3]) : 1.0,
                     argc > 4 ? std::strtoull(argv[4], nullptr, 10) : 7000);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "monte_carlo_unmodelled: %s\n", e.what());
    return 1;
  }
  std::fprintf(stderr, "usage: monte_carlo_unmodelled disturbed|quiet|filter [seeds] [days] [first_seed] | wic [data_dir]\n");
  return 2;
}
