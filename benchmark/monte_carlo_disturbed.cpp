// Monte Carlo of the robust and the plain (Eq. 2) estimators against known truth, and the two
// estimators side by side on the real WIC pair. A program, not a test (minutes of run time);
// its figures are quoted in docs/accuracy.md.
//
//   monte_carlo_disturbed disturbed [seeds=50] [days=5] [first_seed=1000]
//                                                       disturbed station: plain Eq. 2, the robust
//                                                       estimator alone, the default pipeline
//                                                       (MC_ROBUST_ONLY=1: no plain; MC_PIPELINE=0:
//                                                       no pipeline)
//   monte_carlo_disturbed eiv [seeds=200] [days=1]        quiet station, reference noise x10:
//                                                       plain Eq. 2, the robust estimator without
//                                                       and with the simulated noise given
//   monte_carlo_disturbed wic [data_dir=data]             real pair, 4 intervals + the day
//
// Per-seed lines go to stdout prefixed "seed"; the summary follows.
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "magnetometer_insitu_calibration/estimation/robust/robust_estimator.hpp"
#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "magnetometer_insitu_calibration/simulation/station_disturbances.hpp"
#include "magnetometer_insitu_calibration/preprocessing/gap_filling.hpp"

#include "percentile.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

struct Errors {
  Eigen::Vector3d scale_pct, nonorth_deg, misalign_deg;
  int covered = 0, checked = 0;
  double max_scale_pct() const { return scale_pct.cwiseAbs().maxCoeff(); }
  double max_angle_deg() const { return std::max(nonorth_deg.cwiseAbs().maxCoeff(), misalign_deg.cwiseAbs().maxCoeff()); }
};

Errors errors_of(const mic::WindowEstimate& e, const Eigen::Matrix3d& truth) {
  const mic::CalibrationParameters t = mic::decompose(truth);
  const mic::CalibrationParameters& q = e.parameters;
  Errors out;
  out.scale_pct = 100.0 * (q.scale_ratio - t.scale_ratio);
  out.nonorth_deg = q.nonorthogonality_deg - t.nonorthogonality_deg;
  out.misalign_deg = q.misalignment_deg - t.misalignment_deg;
  for (int l = 0; l < 3; ++l) {
    out.covered += std::abs(q.scale_ratio(l) - t.scale_ratio(l)) <= q.scale_ratio_ci95(l);
    out.covered += std::abs(out.nonorth_deg(l)) <= q.nonorthogonality_ci95_deg(l);
    out.covered += std::abs(out.misalign_deg(l)) <= q.misalignment_ci95_deg(l);
    out.checked += 3;
  }
  return out;
}


/// Environment override of a scenario number (for exploring which disturbance does what).
double knob(const char* name, double value) {
  const char* text = std::getenv(name);
  return text != nullptr ? std::atof(text) : value;
}

mic::SimulationSettings station(std::uint64_t seed, double days, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  mic::SimulationSettings s;
  s.seed = seed;
  s.duration_s = days * 86400.0;
  s.keep_clean_field = false;
  // In-band (0.0002-0.01 Hz) rms of about 3 nT in x, y whatever the record length (a quiet
  // mid-latitude day): the simulator fixes the rms over the record, and its f^-2 spectrum puts
  // most of it in the lowest harmonics. Vertical: 0.3 of that (weak, as at Welschbruch).
  s.variation_rms_nT = knob("MC_RMS", 12.5) * std::sqrt(days);
  s.variation_z_ratio = knob("MC_ZRATIO", 0.3);
  s.spikes_per_day = knob("MC_SPIKES", 50);      // 50 nT, caught by the despiker
  s.gap_count = static_cast<int>(2 * days);
  s.gap_length_s = 300.0;
  s.tilt_rate_deg_per_day = knob("MC_TILT", 1.0) * (0.002 + 0.008 * u(rng));  // tilts: drifting baselines
  const double az = 2 * M_PI * u(rng);
  s.tilt_axis = Eigen::Vector3d(std::cos(az), std::sin(az), 0.2 * (u(rng) - 0.5));
  s.drift_nT_per_day = Eigen::Vector3d(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5) * 4.0;
  return s;
}

mic::StationDisturbanceSettings disturbances(std::uint64_t seed) {
  mic::StationDisturbanceSettings d;
  d.seed = seed;
  d.vehicles_per_day = knob("MC_VEHICLES", 150);
  d.road_distance_m = knob("MC_ROAD_M", 40.0);
  d.parking_probability = knob("MC_PARKING", 0.03);
  d.small_spikes_per_day = knob("MC_SMALL_SPIKES", 100);
  d.steps = static_cast<int>(knob("MC_STEPS", 1));
  return d;
}

/// Coverage (of the 9 parameters) that the interval from covariance `cov` gives.
int covered_with(const mic::WindowEstimate& e, const mic::Matrix9d& cov, const Eigen::Matrix3d& truth) {
  mic::WindowEstimate copy = e;
  copy.parameters = mic::decompose(e.n, cov);
  return errors_of(copy, truth).covered;
}

int run_disturbed(int seeds, double days, std::uint64_t first_seed) {
  std::printf("# disturbed station: %d seeds from %llu, %.1f days at 1 Hz, whole record as one window\n", seeds,
              static_cast<unsigned long long>(first_seed), days);
  std::printf("# seed  method  dscale_x%%  dscale_y%%  dscale_z%%  max|dangle|deg  covered/9  delay_ms  screened%%\n");
  mic::CalibrationSettings base;
  std::vector<double> max_scale[3], max_angle[3];
  int covered[3] = {0, 0, 0}, checked[3] = {0, 0, 0}, within_aim[3] = {0, 0, 0};
  int variant_covered[5] = {0, 0, 0, 0, 0}, variant_checked = 0;
  std::mt19937_64 rng(2025);
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k < seeds; ++k) {
    const std::uint64_t seed = first_seed + static_cast<std::uint64_t>(k);
    mic::SimulationSettings s = station(seed, days, rng);
    mic::SimulatedPair pair = mic::simulate_pair(s);
    const mic::StationDisturbanceReport report = mic::add_station_disturbances(pair, disturbances(seed));
    if (knob("MC_DEBUG", 0) > 0) {
      std::printf("  vehicles %zu parked %zu max ref %.2f nT max test %.2f nT\n", report.vehicles, report.parked,
                  report.max_vehicle_reference_nT, report.max_vehicle_test_nT);
    }
    const mic::PreparedPair prepared = mic::prepare_pair(pair.reference, pair.test, base.preprocess);
    // The estimators alone take the record with its gaps filled, as the pipeline fills its window.
    mic::PreparedPair filled = prepared;
    mic::fill_gaps(filled.paired, filled.sample_period_s, base.window.gaps);
    // m: 0 plain Eq. 2, 1 the robust estimator alone (no identified noise: no EIV correction),
    // 2 the default pipeline (calibrate_prepared: the reference's noise from the pair above the
    // band, the response model), as calibrate_records runs it; MC_PIPELINE=0 skips it.
    for (int m = 0; m < 3; ++m) {
      if (m == 0 && knob("MC_ROBUST_ONLY", 0) > 0) continue;
      if (m == 2 && knob("MC_PIPELINE", 1) == 0) continue;
      mic::EstimatorSettings es = base.window.estimator;
      es.method = m == 0 ? mic::EstimatorMethod::kPlain : mic::EstimatorMethod::kRobust;
      es.robust.screen_baseline_s = knob("MC_BASELINE", es.robust.screen_baseline_s);
      es.robust.screen_threshold = knob("MC_THRESHOLD", es.robust.screen_threshold);
      es.robust.section_s = knob("MC_SECTION", es.robust.section_s);
      es.robust.huber_k = knob("MC_HUBER", es.robust.huber_k);
      mic::WindowEstimator estimator(es);
      const auto pipeline_estimate = [&] {
        mic::CalibrationSettings pipeline = base;
        pipeline.window.estimator = es;
        return mic::calibrate_prepared(prepared, pipeline).back().estimate;
      };
      const mic::WindowEstimate e =
          m == 2 ? pipeline_estimate()
                 : estimator.estimate(filled.paired.reference_nT, filled.paired.test_nT, filled.sample_period_s);
      const Errors err = errors_of(e, pair.n_true);
      if (m == 1 && knob("MC_DEBUG", 0) > 0 && estimator.robust_diagnostics() != nullptr) {
        const auto* d = estimator.robust_diagnostics();
        std::printf("  sections %zu cells %zu iterations %d eiv %d delay_corrected %d weights:", d->sections, d->cells,
                    d->iterations, d->eiv_applied, d->delay_corrected);
        for (double w : d->section_weights) std::printf(" %.2f", w);
        std::printf("\n  downweighted %.3f\n", e.downweighted_fraction);
      }
      if (const auto* d = m == 1 ? estimator.robust_diagnostics() : nullptr) {
        // Coverage the other covariance choices would give (sandwich, jackknife, jackknife
        // with Student-t width, per-entry max of the sandwich and the (t-scaled) jackknife).
        const mic::Matrix9d& sw = d->covariance_sandwich;
        const mic::Matrix9d& jk = d->covariance_jackknife;
        if (jk.allFinite() && d->jackknife_sections >= 2) {
          const double t = mic::student_t_two_sided_quantile(0.05, static_cast<double>(d->jackknife_sections - 1)) /
                           mic::kNormalQuantile95;
          auto dmax = [&](const mic::Matrix9d& j) {
            Eigen::Matrix<double, 9, 1> f;
            for (int q = 0; q < 9; ++q) f(q) = std::sqrt(std::max(1.0, j(q, q) / sw(q, q)));
            return mic::Matrix9d(f.asDiagonal() * sw * f.asDiagonal());
          };
          const mic::Matrix9d variants[5] = {sw, jk, t * t * jk, dmax(jk), dmax(t * t * jk)};
          for (int v = 0; v < 5; ++v) variant_covered[v] += covered_with(e, variants[v], pair.n_true);
          variant_checked += 9;
        }
        // Which parameter fails, by how many of its own standard errors, and what the station had.
        const mic::CalibrationParameters t = mic::decompose(pair.n_true);
        Eigen::Matrix<double, 9, 1> z;
        for (int l = 0; l < 3; ++l) {
          z(l) = (e.parameters.scale_ratio(l) - t.scale_ratio(l)) / (e.parameters.scale_ratio_ci95(l) / 1.959964);
          z(3 + l) = err.nonorth_deg(l) / (e.parameters.nonorthogonality_ci95_deg(l) / 1.959964);
          z(6 + l) = err.misalign_deg(l) / (e.parameters.misalignment_ci95_deg(l) / 1.959964);
        }
        std::printf("detail %4llu errs %% %.4f %.4f %.4f nonorth %.4f %.4f %.4f mis %.4f %.4f %.4f | z", static_cast<unsigned long long>(seed),
                    err.scale_pct(0), err.scale_pct(1), err.scale_pct(2), err.nonorth_deg(0), err.nonorth_deg(1),
                    err.nonorth_deg(2), err.misalign_deg(0), err.misalign_deg(1), err.misalign_deg(2));
        for (int q = 0; q < 9; ++q) std::printf(" %.1f", z(q));
        std::printf(" | parked %zu steps %zu maxref %.1f tilt %.4f sections %zu rejected %d screened %.2f%%\n",
                    report.parked, report.steps, report.max_vehicle_reference_nT, s.tilt_rate_deg_per_day, d->sections,
                    static_cast<int>(std::count(d->section_weights.begin(), d->section_weights.end(), 0.0)),
                    100.0 * e.screened_fraction);
      }
      max_scale[m].push_back(err.max_scale_pct());
      max_angle[m].push_back(err.max_angle_deg());
      covered[m] += err.covered;
      checked[m] += err.checked;
      within_aim[m] += err.max_scale_pct() <= 0.05 && err.max_angle_deg() <= 0.03;
      std::printf("seed %4llu %-6s %9.4f %9.4f %9.4f %10.4f %5d %9.2f %7.2f\n", static_cast<unsigned long long>(seed),
                  m == 2 ? "default" : e.method.c_str(), err.scale_pct(0), err.scale_pct(1), err.scale_pct(2), err.max_angle_deg(),
                  err.covered, e.delay_s * 1e3, 100.0 * e.screened_fraction);
      std::fflush(stdout);
    }
  }
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("\n| estimator | 95th pct max scale-ratio error | 95th pct max angle error | seeds within 0.05 %% and 0.03 deg | median max scale error | median max angle error | interval coverage (9 parameters x seeds) |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  for (int m = 0; m < 3; ++m) {
    if (max_scale[m].empty()) continue;
    std::printf("| %s | %.4f %% | %.4f deg | %d / %d | %.4f %% | %.4f deg | %.1f %% |\n", m == 0 ? "plain Eq. 2" : (m == 1 ? "robust estimator alone" : "default (pipeline: pair's noise, response model)"),
                percentile(max_scale[m], 0.95), percentile(max_angle[m], 0.95), within_aim[m], seeds,
                percentile(max_scale[m], 0.5), percentile(max_angle[m], 0.5), 100.0 * covered[m] / std::max(1, checked[m]));
  }
  std::printf("# robust coverage by covariance: sandwich %.1f %%, jackknife %.1f %%, jackknife t %.1f %%, max(sandwich, jackknife) %.1f %%, max(sandwich, jackknife t) %.1f %%\n",
              100.0 * variant_covered[0] / std::max(1, variant_checked), 100.0 * variant_covered[1] / std::max(1, variant_checked),
              100.0 * variant_covered[2] / std::max(1, variant_checked), 100.0 * variant_covered[3] / std::max(1, variant_checked),
              100.0 * variant_covered[4] / std::max(1, variant_checked));
  std::printf("# %.0f s for %d seeds\n", elapsed, seeds);
  return 0;
}

int run_eiv(int seeds, double days) {
  std::printf("# quiet station, reference noise x10 (white 0.1 nT, pink 0.05 nT/sqrt(Hz) at 1 Hz): %d seeds, %.1f days\n", seeds, days);
  const char* names[] = {"plain Eq. 2", "robust, no EIV correction", "robust, EIV given noise"};
  const int methods = 3;
  std::vector<Eigen::Vector3d> sum_err(methods, Eigen::Vector3d::Zero()), sum_se(methods, Eigen::Vector3d::Zero()),
      sum_err2(methods, Eigen::Vector3d::Zero());
  int covered[methods] = {0}, checked[methods] = {0};
  std::mt19937_64 rng(7);
  for (int k = 0; k < seeds; ++k) {
    mic::SimulationSettings s;
    s.seed = 5000 + static_cast<std::uint64_t>(k);
    s.duration_s = days * 86400.0;
    s.keep_clean_field = false;
    s.variation_rms_nT = 5.0 * std::sqrt(days);
    s.reference_white_nT *= 10.0;
    s.reference_pink_nT_per_sqrt_hz *= 10.0;
    const mic::SimulatedPair pair = mic::simulate_pair(s);
    const mic::CalibrationParameters truth = mic::decompose(pair.n_true);
    for (int m = 0; m < methods; ++m) {
      mic::EstimatorSettings es;
      es.method = m == 0 ? mic::EstimatorMethod::kPlain : mic::EstimatorMethod::kRobust;
      mic::WindowInputs inputs;  // m == 1: no noise model, no correction
      if (m == 2) {  // the simulated reference noise, given as a maker's figure would be
        mic::NoiseSpectrum figure;
        figure.white_nT.setConstant(s.reference_white_nT);
        figure.pink_nT_per_sqrt_hz.setConstant(s.reference_pink_nT_per_sqrt_hz);
        inputs.reference_noise = mic::ReferenceNoiseModel::maker_figure(figure);
      }
      mic::WindowEstimator estimator(es);
      const mic::WindowEstimate e = estimator.estimate(pair.reference.values_nT, pair.test.values_nT, 1.0, inputs);
      const Eigen::Vector3d err = e.parameters.scale_ratio - truth.scale_ratio;
      sum_err[m] += err;
      sum_err2[m] += err.cwiseAbs2();
      sum_se[m] += e.parameters.scale_ratio_ci95 / 1.959964;
      const Errors full = errors_of(e, pair.n_true);
      covered[m] += full.covered;
      checked[m] += full.checked;
    }
  }
  std::printf("\n| estimator | bias x, y, z (ppm) | bias / standard error x, y, z | scatter / stated se x, y, z | coverage |\n|---|---|---|---|---|\n");
  for (int m = 0; m < methods; ++m) {
    const Eigen::Vector3d bias = sum_err[m] / seeds, se = sum_se[m] / seeds;
    const Eigen::Vector3d scatter = (sum_err2[m] / seeds - bias.cwiseAbs2()).cwiseSqrt();
    std::printf("| %s | %.1f, %.1f, %.1f | %.2f, %.2f, %.2f | %.2f, %.2f, %.2f | %.1f %% |\n", names[m], bias(0) * 1e6,
                bias(1) * 1e6, bias(2) * 1e6, bias(0) / scatter(0), bias(1) / scatter(1), bias(2) / scatter(2),
                scatter(0) / se(0), scatter(1) / se(1), scatter(2) / se(2), 100.0 * covered[m] / std::max(1, checked[m]));
  }
  std::printf("# bias: mean error of the scale ratio over the seeds; its own standard error is scatter / sqrt(%d)\n", seeds);
  return 0;
}

int run_wic(const std::string& dir) {
  const mic::VectorRecord reference = mic::read_record(dir + "/wic20250514_lemi036.sec.gz");
  const mic::VectorRecord test = mic::read_record(dir + "/wic20250514_fge.sec.gz");
  std::printf("| window | method | band Hz | Kt/Kr H, E, Z (95 %%) | non-orthogonality HE, HZ, EZ deg | misalignment deg | delay ms | screened %% | quality |\n|---|---|---|---|---|---|---|---|---|\n");
  for (int variant = 0; variant < 3; ++variant) {
    mic::CalibrationSettings settings;
    settings.windows.intervals = 4;
    settings.window.estimator.method = variant == 0 ? mic::EstimatorMethod::kPlain : mic::EstimatorMethod::kRobust;
    settings.window.estimator.robust.auto_band = variant == 2;
    const mic::PairCalibration result = mic::calibrate_records(reference, test, settings);
    for (const auto& w : result.windows) {
      const auto& e = w.estimate;
      const auto& q = e.parameters;
      std::printf("| %s | %s%s | %.5f-%.4f | %.5f+-%.5f, %.5f+-%.5f, %.5f+-%.5f | %.3f+-%.3f, %.3f+-%.3f, %.3f+-%.3f | %.3f, %.3f, %.3f | %.1f+-%.1f | %.1f | %s |\n",
                  w.label.c_str(), e.method.c_str(), variant == 2 ? " auto-band" : "", e.band_low_hz, e.band_high_hz,
                  q.scale_ratio(0), q.scale_ratio_ci95(0), q.scale_ratio(1), q.scale_ratio_ci95(1), q.scale_ratio(2),
                  q.scale_ratio_ci95(2), q.nonorthogonality_deg(0), q.nonorthogonality_ci95_deg(0), q.nonorthogonality_deg(1),
                  q.nonorthogonality_ci95_deg(1), q.nonorthogonality_deg(2), q.nonorthogonality_ci95_deg(2),
                  q.misalignment_deg(0), q.misalignment_deg(1), q.misalignment_deg(2), e.delay_s * 1e3, e.delay_ci95_s * 1e3,
                  100.0 * e.screened_fraction, e.quality_text.c_str());
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "disturbed";
  try {
    if (mode == "disturbed")
      return run_disturbed(argc > 2 ? std::atoi(argv[2]) : 50, argc > 3 ? std::atof(argv[3]) : 5.0,
                           argc > 4 ? std::strtoull(argv[4], nullptr, 10) : 1000);
    if (mode == "eiv") return run_eiv(argc > 2 ? std::atoi(argv[2]) : 200, argc > 3 ? std::atof(argv[3]) : 1.0);
    if (mode == "wic") return run_wic(argc > 2 ? argv[2] : "data");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "monte_carlo_disturbed: %s\n", e.what());
    return 1;
  }
  std::fprintf(stderr, "usage: monte_carlo_disturbed disturbed|eiv|wic [...]\n");
  return 2;
}
