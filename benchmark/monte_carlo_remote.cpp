// Monte Carlo of the remote reference (estimation/remote_reference.hpp) against known truth: on
// the same simulated records, plain Eq. 2 on the pair, the default estimator on the pair alone,
// and the default with a remote observatory's record as its instruments. A program, not a test
// (minutes of run time); its figures are quoted in docs/accuracy.md.
//
//   monte_carlo_remote disturbed [seeds=50] [days=5] [first_seed=40000]
//   monte_carlo_remote quiet [seeds=100] [days=2] [first_seed=42000]
//   monte_carlo_remote filter [seeds=100] [days=2] [first_seed=44000]
//                       quiet, the test behind a 1-pole low-pass at 0.03 Hz and a 2 s delay
//                       (MC_CORNER, MC_DELAY): the relative response's gain and phase against
//                       the true filter, per band up to 0.05 Hz
//
// The stations are monte_carlo_unmodelled's (unmodelled_scenario.hpp) with, on the disturbed
// one, a busy road: 600 vehicles a day (25 an hour) 60 m from the sensors, one in ten parking
// for 2 min to 1 h (MC_VEHICLES, MC_ROAD_M, MC_PARKING when set), each seen by both sensors with
// different gains and directions; and spikes, gaps, a tilt walk of the test pier, heater
// cycling and a response mismatch. "quiet": the simulator's defaults. The remote (remote_observatory.hpp) sees
// the field but none of the local disturbances: MC_REMOTE_INCOHERENT (0.2) of its variations'
// variance its own, its own noise (simulator defaults), orientation and Z response, and
// MC_REMOTE_GAPS (1) gaps of 10 min per day; MC_REMOTE_Z_INCOHERENT the own share of its vertical
// alone (unset: MC_REMOTE_INCOHERENT's); MC_REMOTE_COHERENCE_HZ its coherence corner (its own
// share rising with frequency, remote_observatory.hpp; unset: the same share at every frequency).
// MC_REMOTE_BAND_HIGH (Hz): the remote-reference estimate's band top (calibrate_records --band
// 0.0002:F --remote ...), the other two estimators keeping the default's 0.01 Hz; MC_REMOTE_BAND_LOW
// (Hz) its bottom likewise.
// Each record is one window. MC_PAIR_NOISE=0: the reference's noise not identified from the pair
// (calibrate_records --no-pair-noise). Without a remote the default's two checks of the pair
// alone are counted: the band split and the local-event check (records flagged, the coverage of
// the others, misses neither flagged).
//
// Per-seed lines go to stdout prefixed "seed"; the summary table follows.
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_summary.hpp"
#include "magnetometer_insitu_calibration/simulation/remote_observatory.hpp"

#include "unmodelled_scenario.hpp"

#include "parameter_errors.hpp"
#include "percentile.hpp"

#include <algorithm>
#include <chrono>
#include <complex>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;
using monte_carlo::knob;

namespace {

constexpr int kMethods = 3;
const char* const kMethodNames[kMethods] = {"plain Eq. 2 (pair)", "default, pair only", "default, remote reference"};

struct Tally {
  std::vector<double> max_scale_pct, max_angle_deg;
  int covered = 0, checked = 0, flagged = 0, used = 0;
  // Without a remote: windows whose band halves differ (not vouched for), and the coverage of
  // the others.
  int split_flagged = 0, unflagged_covered = 0, unflagged_checked = 0, missed_unflagged = 0;
  // Without a remote: windows where the local-event check saw events (not vouched for), the
  // coverage of the others, and windows missing a parameter that neither check flagged.
  int events_seen = 0, events_assessed = 0, unseen_covered = 0, unseen_checked = 0, missed_unseen = 0, missed_unflagged_either = 0;
  // Without a remote: windows not vouched for (calibration_summary.hpp), the coverage of the others.
  int doubted = 0, vouched_covered = 0, vouched_checked = 0;
  // The relative response against the true filter (kind "filter"): gain and phase values inside
  // their intervals, bands up to the estimation band's top and up to 0.05 Hz.
  int response_inside[2] = {0, 0}, response_checked[2] = {0, 0};
  double seconds = 0.0;
};


/// The relative response's bands against the test's true filter H(f) = e^{-2 pi i f delay} /
/// (1 + i f / corner): gain and phase inside their 95 % intervals, for bands up to 0.01 Hz and up
/// to 0.05 Hz.
void score_response(const std::vector<mic::ResponseBand>& bands, Tally& tally) {
  const double corner = knob("MC_CORNER", 0.03), delay = knob("MC_DELAY", 2.0);
  for (const mic::ResponseBand& b : bands) {
    if (b.frequency_hz > 0.05) continue;
    const std::complex<double> h = std::polar(1.0, -2.0 * M_PI * b.frequency_hz * delay) /
                                   std::complex<double>(1.0, b.frequency_hz / corner);
    const double gain = std::abs(h), phase = std::arg(h) * 180.0 / M_PI;
    for (int k = 0; k < 3; ++k) {
      const int inside = (std::abs(b.gain(k) - gain) <= b.gain_ci95(k)) + (std::abs(b.phase_deg(k) - phase) <= b.phase_ci95_deg(k));
      for (int r = b.frequency_hz <= 0.01 ? 0 : 1; r < 2; ++r) {
        tally.response_inside[r] += inside;
        tally.response_checked[r] += 2;
      }
    }
  }
}

/// Largest |error| of the scale ratios (%) and of the angles (deg), and how many of the nine
/// parameters' 95 % intervals hold the truth.
void score(const mic::WindowEstimate& e, const Eigen::Matrix3d& truth, Tally& tally, double& scale, double& angle,
           int& covered) {
  const monte_carlo::ParameterErrors errors = monte_carlo::parameter_errors(e.parameters, truth);
  scale = errors.scale_pct;
  angle = errors.angle_deg;
  covered = errors.covered;
  tally.max_scale_pct.push_back(scale);
  tally.max_angle_deg.push_back(angle);
  tally.covered += covered;
  tally.checked += 9;
}

int run(const std::string& kind, int seeds, double days, std::uint64_t first_seed) {
  std::printf("# %s station: %d seeds from %llu, %.1f days at 1 Hz, whole record as one window\n", kind.c_str(), seeds,
              static_cast<unsigned long long>(first_seed), days);
  std::printf("# remote: %.0f %% of its variations' variance its own (rising with frequency, corner %g Hz), %.0f gaps "
              "of 10 min per day\n",
              100.0 * knob("MC_REMOTE_INCOHERENT", 0.2), knob("MC_REMOTE_COHERENCE_HZ", std::numeric_limits<double>::infinity()),
              knob("MC_REMOTE_GAPS", 1.0));
  if (knob("MC_REMOTE_BAND_HIGH", 0.0) > 0.0) {
    std::printf("# the remote-reference estimate's band: up to %g Hz\n", knob("MC_REMOTE_BAND_HIGH", 0.0));
  }
  if (knob("MC_REMOTE_BAND_LOW", 0.0) > 0.0) {
    std::printf("# the remote-reference estimate's band: from %g Hz\n", knob("MC_REMOTE_BAND_LOW", 0.0));
  }
  std::printf("# seed  method  max|dscale|%%  max|dangle|deg  covered/9  F  pair_biased  band_halves_differ  local_events_z  "
              "remote_coherence_x_y_z\n");
  Tally tally[kMethods];
  for (int k = 0; k < seeds; ++k) {
    const std::uint64_t seed = first_seed + static_cast<std::uint64_t>(k);
    mic::SimulationSettings s;
    const mic::SimulatedPair pair = monte_carlo::station_records(kind, seed, days, true, &s);
    mic::RemoteObservatorySettings r;
    r.seed = seed + 7000;
    r.incoherent_fraction = knob("MC_REMOTE_INCOHERENT", 0.2);
    r.z_incoherent_fraction = knob("MC_REMOTE_Z_INCOHERENT", r.incoherent_fraction);
    r.coherence_corner_hz = knob("MC_REMOTE_COHERENCE_HZ", std::numeric_limits<double>::infinity());
    r.gap_count = static_cast<int>(knob("MC_REMOTE_GAPS", 1.0) * days);
    const mic::VectorRecord remote = mic::simulate_remote_observatory(s, pair, r);
    mic::CalibrationSettings settings;
    if (knob("MC_PAIR_NOISE", 1.0) == 0.0) settings.window.pair_noise = false;  // calibrate_records --no-pair-noise
    const mic::PreparedPair prepared = mic::prepare_pair(pair.reference, pair.test, settings.preprocess);
    const mic::PreparedSides sides = mic::prepare_sides(pair.reference, prepared, {nullptr, &remote}, settings);
    for (int m = 0; m < kMethods; ++m) {
      mic::CalibrationSettings cs = settings;
      if (m == 0) {
        cs.window.estimator.method = mic::EstimatorMethod::kPlain;
        cs.window.response_model = false;
      }
      if (m == 2 && knob("MC_REMOTE_BAND_HIGH", 0.0) > 0.0) cs.window.estimator.band_high_hz = knob("MC_REMOTE_BAND_HIGH", 0.0);
      if (m == 2 && knob("MC_REMOTE_BAND_LOW", 0.0) > 0.0) cs.window.estimator.band_low_hz = knob("MC_REMOTE_BAND_LOW", 0.0);
      const auto start = std::chrono::steady_clock::now();
      const mic::CalibrationWindow w = mic::calibrate_prepared(prepared, cs, m == 2 ? &sides : nullptr).back();
      tally[m].seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      double scale = 0.0, angle = 0.0;
      int covered = 0;
      score(w.estimate, pair.n_true, tally[m], scale, angle, covered);
      if (kind == "filter") score_response(w.relative_response, tally[m]);
      const mic::RemoteReference& rr = w.estimate.remote;
      tally[m].flagged += rr.pair_biased;
      tally[m].used += rr.used;
      if (!rr.used) {
        const bool differs = w.estimate.band_split.differs;
        tally[m].split_flagged += differs;
        if (!differs) {
          tally[m].unflagged_covered += covered;
          tally[m].unflagged_checked += 9;
          tally[m].missed_unflagged += covered < 9;
        }
        const mic::LocalEventCheck& events = w.estimate.local_events;
        tally[m].events_assessed += events.assessed;
        tally[m].events_seen += events.seen;
        if (!events.seen) {
          tally[m].unseen_covered += covered;
          tally[m].unseen_checked += 9;
          tally[m].missed_unseen += covered < 9;
        }
        tally[m].missed_unflagged_either += covered < 9 && !events.seen && !differs;
        const bool doubted = !mic::not_vouched_for(w.estimate).empty();
        tally[m].doubted += doubted;
        if (!doubted) {
          tally[m].vouched_covered += covered;
          tally[m].vouched_checked += 9;
        }
      }
      std::printf("seed %5llu %d %9.4f %9.4f %d %7.0f %d %d %6.2f %5.3f %5.3f %5.3f%s%s\n",
                  static_cast<unsigned long long>(seed), m, scale, angle, covered, rr.strength, rr.pair_biased ? 1 : 0,
                  w.estimate.band_split.differs ? 1 : 0, w.estimate.local_events.z, rr.coherence(0), rr.coherence(1),
                  rr.coherence(2), m == 2 && !rr.used ? " " : "", m == 2 && !rr.used ? rr.text.c_str() : "");
      if (knob("MC_DEBUG", 0) > 0) {
        const mic::CalibrationParameters t = mic::decompose(pair.n_true);
        const mic::CalibrationParameters& q = w.estimate.parameters;
        std::printf("  errors/ci95: scale %.4f/%.4f %.4f/%.4f %.4f/%.4f %%; nonorth %.3f/%.3f %.3f/%.3f %.3f/%.3f; mis %.3f/%.3f %.3f/%.3f %.3f/%.3f deg; %s; %s\n",
                    100 * (q.scale_ratio(0) - t.scale_ratio(0)), 100 * q.scale_ratio_ci95(0),
                    100 * (q.scale_ratio(1) - t.scale_ratio(1)), 100 * q.scale_ratio_ci95(1),
                    100 * (q.scale_ratio(2) - t.scale_ratio(2)), 100 * q.scale_ratio_ci95(2),
                    q.nonorthogonality_deg(0) - t.nonorthogonality_deg(0), q.nonorthogonality_ci95_deg(0),
                    q.nonorthogonality_deg(1) - t.nonorthogonality_deg(1), q.nonorthogonality_ci95_deg(1),
                    q.nonorthogonality_deg(2) - t.nonorthogonality_deg(2), q.nonorthogonality_ci95_deg(2),
                    q.misalignment_deg(0) - t.misalignment_deg(0), q.misalignment_ci95_deg(0),
                    q.misalignment_deg(1) - t.misalignment_deg(1), q.misalignment_ci95_deg(1),
                    q.misalignment_deg(2) - t.misalignment_deg(2), q.misalignment_ci95_deg(2),
                    w.estimate.intervals.c_str(), rr.text.c_str());
      }
      std::fflush(stdout);
    }
  }
  std::printf("\n| estimator | median / 95th pct max scale-ratio error | median / 95th pct max angle error | "
              "coverage (9 parameters x seeds) | pair-only estimate flagged biased | CPU s per record |\n|---|---|---|---|---|---|\n");
  std::string split_lines;
  for (int m = 0; m < kMethods; ++m) {
    const Tally& t = tally[m];
    std::printf("| %s | %.3f / %.3f %% | %.4f / %.4f deg | %.1f %% | %s | %.2f |\n", kMethodNames[m],
                percentile(t.max_scale_pct, 0.5), percentile(t.max_scale_pct, 0.95), percentile(t.max_angle_deg, 0.5),
                percentile(t.max_angle_deg, 0.95), 100.0 * t.covered / std::max(1, t.checked),
                m == 2 ? (std::to_string(t.flagged) + " of " + std::to_string(t.used) + " records with the remote").c_str() : "",
                t.seconds / std::max(1, seeds));
    if (kind == "filter") {
      char line[512];
      std::snprintf(line, sizeof line, "# %s: relative response inside its 95 %% intervals: %.1f %% to 0.01 Hz, %.1f %% to 0.05 Hz\n",
                    kMethodNames[m], 100.0 * t.response_inside[0] / std::max(1, t.response_checked[0]),
                    100.0 * t.response_inside[1] / std::max(1, t.response_checked[1]));
      split_lines += line;
    }
    if (m == 1) {
      char line[512];
      std::snprintf(line, sizeof line,
                    "# %s: band halves differ in %d of %d records; coverage of the others %.1f %%, %d of them miss "
                    "a parameter\n",
                    kMethodNames[m], t.split_flagged, seeds, 100.0 * t.unflagged_covered / std::max(1, t.unflagged_checked),
                    t.missed_unflagged);
      split_lines += line;
      char others[64] = "none";
      if (t.unseen_checked > 0) std::snprintf(others, sizeof others, "%.1f %%", 100.0 * t.unseen_covered / t.unseen_checked);
      std::snprintf(line, sizeof line,
                    "# %s: local events seen in %d of %d records (%d assessed); coverage of the others %s, %d of "
                    "them miss a parameter; %d records miss a parameter with neither check flagging\n",
                    kMethodNames[m], t.events_seen, seeds, t.events_assessed, others, t.missed_unseen,
                    t.missed_unflagged_either);
      split_lines += line;
      std::snprintf(line, sizeof line, "# %s: not vouched for in %d of %d records; coverage of the others %.1f %%\n",
                    kMethodNames[m], t.doubted, seeds, 100.0 * t.vouched_covered / std::max(1, t.vouched_checked));
      split_lines += line;
    }
  }
  std::printf("%s", split_lines.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string kind = argc > 1 ? argv[1] : "disturbed";
  if (kind != "disturbed" && kind != "quiet" && kind != "filter") {
    std::fprintf(stderr, "usage: monte_carlo_remote disturbed|quiet|filter [seeds] [days] [first_seed]\n");
    return 2;
  }
  const bool disturbed = kind == "disturbed";
  // The busy road (overwrite 0: a knob given in the environment stays).
  setenv("MC_VEHICLES", "600", 0);
  setenv("MC_ROAD_M", "60", 0);
  setenv("MC_PARKING", "0.1", 0);
  const int seeds = argc > 2 ? std::atoi(argv[2]) : (disturbed ? 50 : 100);
  const double days = argc > 3 ? std::atof(argv[3]) : (disturbed ? 5.0 : 2.0);
  const std::uint64_t first =
      argc > 4 ? std::strtoull(argv[4], nullptr, 10) : (disturbed ? 40000 : (kind == "quiet" ? 42000 : 44000));
  return run(kind, seeds, days, first);
}
