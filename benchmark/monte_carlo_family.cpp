// Monte Carlo of the pair's checks and intervals over a family of disturbed stations
// (simulation/disturbance_classes.hpp), each record one window: the default estimator on the pair
// alone and with a remote observatory's record as its instruments. A program, not a test
// (minutes of run time); its figures are quoted in docs/accuracy.md.
//
//   monte_carlo_family [classes=all] [seeds_per_class=20] [days=5] [first_seed=90000]
//
// classes: "all" or names separated by commas. Seed of station k of the i-th class listed in
// disturbance_class_names(): first_seed + 50 i + k (k < 50), so that a range of 1000 seeds holds
// every class's stations.
// The remote (remote_observatory.hpp) sees the field but none of the local disturbances; per
// station its own share of the variations' variance is drawn uniformly in 0-0.5 and the own
// share of its vertical uniformly between that and 0.5 (a vertical less coherent than the
// horizontals), its Z gain 0.7 plus 0.1 of x, one 10-minute gap a day.
// Six parameters: the three scale ratios and the three non-orthogonalities; scale error the
// largest |error| of the scale ratios (%), angle error the largest of the non-orthogonalities
// (deg). "Flagged": the summary's "not vouched for" (calibration_summary.hpp: local events seen,
// or band halves that differ by more than the intervals carry).
//
// Switches for finding what costs a class its coverage (environment):
//   MC_PAIR_ONLY=1          the remote's estimate not made (its columns then repeat the pair's);
//   MC_EIV=truth|none       the reference's true noise given as its figure, or no pair noise
//                           identified (default: identified from the pair, as calibrate_records);
//   MC_OFF=tilt,heater,filter,spikes,gaps   parts of the base station left out;
//   MC_Z=1                  a line "zs" per estimate scored (pair, pair without the halves'
//                           spread, remote): each parameter's error over its standard error
//                           (sx sy sz nxy nxz nyz) and the covariance's degrees of freedom.
//
// Per-seed lines go to stdout prefixed "seed"; the summary table follows.
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_summary.hpp"
#include "magnetometer_insitu_calibration/simulation/disturbance_classes.hpp"
#include "magnetometer_insitu_calibration/simulation/remote_observatory.hpp"

#include "percentile.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

struct Tally {
  std::vector<double> scale_pct, angle_deg;
  int stations = 0, covered = 0, checked = 0, flagged = 0, unflagged_covered = 0, unflagged_checked = 0;
  int refused = 0, pair_biased = 0;
  // Pair only: the coverage without the halves' spread, windows with local events seen, windows
  // whose intervals the spread widened.
  int narrow_stations = 0, narrow_covered = 0, events = 0, widened = 0;

  void add(const Tally& o) {
    scale_pct.insert(scale_pct.end(), o.scale_pct.begin(), o.scale_pct.end());
    angle_deg.insert(angle_deg.end(), o.angle_deg.begin(), o.angle_deg.end());
    for (int Tally::*count : {&Tally::stations, &Tally::covered, &Tally::checked, &Tally::flagged,
                              &Tally::unflagged_covered, &Tally::unflagged_checked, &Tally::refused,
                              &Tally::pair_biased, &Tally::narrow_stations, &Tally::narrow_covered, &Tally::events,
                              &Tally::widened}) {
      this->*count += o.*count;
    }
  }
};

/// Six parameters of the window against the truth: largest scale error (%), largest
/// non-orthogonality error (deg), how many inside their 95 % intervals.
int score(const mic::WindowEstimate& e, const Eigen::Matrix3d& truth, double& scale, double& angle) {
  const mic::CalibrationParameters t = mic::decompose(truth);
  const mic::CalibrationParameters& q = e.parameters;
  const Eigen::Vector3d ds = 100.0 * (q.scale_ratio - t.scale_ratio);
  const Eigen::Vector3d dn = q.nonorthogonality_deg - t.nonorthogonality_deg;
  scale = ds.cwiseAbs().maxCoeff();
  angle = dn.cwiseAbs().maxCoeff();
  int covered = 0;
  if (std::getenv("MC_Z")) {
    std::printf("zs");
    for (int l = 0; l < 3; ++l) std::printf(" %.2f", 1.96 * ds(l) / (100.0 * q.scale_ratio_ci95(l)));
    for (int l = 0; l < 3; ++l) std::printf(" %.2f", 1.96 * dn(l) / q.nonorthogonality_ci95_deg(l));
    std::printf(" dof %.0f\n", e.covariance_dof);
  }
  for (int l = 0; l < 3; ++l) {
    covered += std::abs(ds(l)) <= 100.0 * q.scale_ratio_ci95(l);
    covered += std::abs(dn(l)) <= q.nonorthogonality_ci95_deg(l);
  }
  return covered;
}

std::string share(int part, int whole) {
  char text[32];
  if (whole == 0) return "-";
  std::snprintf(text, sizeof text, "%.1f %%", 100.0 * part / whole);
  return text;
}

void print_row(const std::string& name, const Tally& pair, const Tally& remote) {
  std::printf("| %s | %d | %s | %s | %s | %s | %s | %s | %.3f / %.3f %% | %.3f / %.3f deg | %s | %.3f / %.3f %% | %.3f / %.3f deg | %d |\n",
              name.c_str(), pair.stations, share(pair.narrow_covered, 6 * pair.narrow_stations).c_str(),
              share(pair.covered, pair.checked).c_str(), share(pair.widened, pair.stations).c_str(),
              share(pair.unflagged_covered, pair.unflagged_checked).c_str(), share(pair.flagged, pair.stations).c_str(),
              share(pair.events, pair.stations).c_str(),
              percentile(pair.scale_pct, 0.5), percentile(pair.scale_pct, 0.95), percentile(pair.angle_deg, 0.5),
              percentile(pair.angle_deg, 0.95), share(remote.covered, remote.checked).c_str(), percentile(remote.scale_pct, 0.5),
              percentile(remote.scale_pct, 0.95), percentile(remote.angle_deg, 0.5), percentile(remote.angle_deg, 0.95),
              remote.refused);
}

/// One station: the pair-only and the remote-reference default on its record.
void run_station(const std::string& name, std::uint64_t seed, double days, Tally& pair_tally, Tally& remote_tally) {
  mic::DisturbanceClassSettings c = mic::disturbance_class(name, seed, days);
  if (const char* off = std::getenv("MC_OFF")) {
    const std::string o(off);
    if (o.find("tilt") != std::string::npos) c.unmodelled.tilt_walk_nT_per_sqrt_day = 0.0;
    if (o.find("heater") != std::string::npos) c.unmodelled.heater_nT.setZero();
    if (o.find("filter") != std::string::npos) { c.unmodelled.test_corner_hz = 0.0; c.unmodelled.test_delay_s = 0.0; }
    if (o.find("spikes") != std::string::npos) { c.simulation.spikes_per_day = 0; c.station.small_spikes_per_day = 0; }
    if (o.find("gaps") != std::string::npos) c.simulation.gap_count = 0;
  }
  c.simulation.keep_clean_field = true;  // the remote's field
  const mic::SimulatedPair pair = mic::simulate_disturbance_class(c);
  std::mt19937_64 rng(seed * 31337 + 5);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  mic::RemoteObservatorySettings r;
  r.seed = seed + 7000;
  r.incoherent_fraction = 0.5 * uniform(rng);
  r.z_incoherent_fraction = r.incoherent_fraction + (0.5 - r.incoherent_fraction) * uniform(rng);
  r.gap_count = static_cast<int>(days);
  const mic::VectorRecord remote = mic::simulate_remote_observatory(c.simulation, pair, r);
  mic::CalibrationSettings settings;
  if (const char* eiv = std::getenv("MC_EIV")) {
    if (std::string(eiv) == "truth") {
      settings.window.reference_noise_figure.white_nT = Eigen::Vector3d::Constant(c.simulation.reference_white_nT);
      settings.window.reference_noise_figure.pink_nT_per_sqrt_hz = Eigen::Vector3d::Constant(c.simulation.reference_pink_nT_per_sqrt_hz);
    } else if (std::string(eiv) == "none") {
      settings.window.pair_noise = false;
    }
  }
  const mic::PreparedPair prepared = mic::prepare_pair(pair.reference, pair.test, settings.preprocess);
  const mic::PreparedSides sides = mic::prepare_sides(pair.reference, prepared, {nullptr, &remote}, settings);
  const mic::CalibrationWindow alone = mic::calibrate_prepared(prepared, settings, nullptr).back();
  const bool pair_only = std::getenv("MC_PAIR_ONLY") != nullptr && std::atoi(std::getenv("MC_PAIR_ONLY")) != 0;
  const mic::CalibrationWindow with = mic::calibrate_prepared(prepared, settings, pair_only ? nullptr : &sides).back();
  double scale = 0.0, angle = 0.0;
  const int covered = score(alone.estimate, pair.n_true, scale, angle);
  // The same window's intervals without the band halves' spread (BandSplitCheck::spread_covariance).
  mic::WindowEstimate narrow = alone.estimate;
  narrow.parameters = mic::decompose(narrow.n, narrow.n_covariance - narrow.band_split.spread_covariance, narrow.covariance_dof);
  const int covered_narrow = score(narrow, pair.n_true, scale, angle);
  ++pair_tally.narrow_stations;
  pair_tally.narrow_covered += covered_narrow;
  pair_tally.events += alone.estimate.local_events.seen;
  pair_tally.widened += alone.estimate.band_split.intervals_widened;
  const bool flagged = !mic::not_vouched_for(alone.estimate).empty();
  pair_tally.scale_pct.push_back(scale);
  pair_tally.angle_deg.push_back(angle);
  ++pair_tally.stations;
  pair_tally.covered += covered;
  pair_tally.checked += 6;
  pair_tally.flagged += flagged;
  if (!flagged) {
    pair_tally.unflagged_covered += covered;
    pair_tally.unflagged_checked += 6;
  }
  double remote_scale = 0.0, remote_angle = 0.0;
  const int remote_covered = score(with.estimate, pair.n_true, remote_scale, remote_angle);
  remote_tally.scale_pct.push_back(remote_scale);
  remote_tally.angle_deg.push_back(remote_angle);
  ++remote_tally.stations;
  remote_tally.covered += remote_covered;
  remote_tally.checked += 6;
  remote_tally.refused += !with.estimate.remote.used;
  remote_tally.pair_biased += with.estimate.remote.pair_biased;
  std::printf("seed %s %llu pair %.4f %.4f %d (narrow %d) split_p %.3g events_z %.2f flagged %d | remote %.4f %.4f %d F %.0f own %.2f/%.2f\n",
              name.c_str(), static_cast<unsigned long long>(seed), scale, angle, covered, covered_narrow,
              alone.estimate.band_split.p_value, alone.estimate.local_events.z, flagged ? 1 : 0, remote_scale,
              remote_angle, remote_covered, with.estimate.remote.strength, r.incoherent_fraction, r.z_incoherent_fraction);
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> classes;
  const std::string list = argc > 1 ? argv[1] : "all";
  if (list == "all") {
    classes = mic::disturbance_class_names();
  } else {
    std::stringstream stream(list);
    for (std::string item; std::getline(stream, item, ',');) classes.push_back(item);
  }
  const int seeds = argc > 2 ? std::atoi(argv[2]) : 20;
  const double days = argc > 3 ? std::atof(argv[3]) : 5.0;
  const std::uint64_t first = argc > 4 ? std::strtoull(argv[4], nullptr, 10) : 90000;
  if (seeds < 1 || seeds > 50 || !(days > 0.0)) {
    std::fprintf(stderr, "usage: monte_carlo_family [all|CLASS,...] [seeds_per_class 1-50] [days] [first_seed]\n");
    return 2;
  }
  const std::vector<std::string>& names = mic::disturbance_class_names();
  std::vector<Tally> pair(classes.size()), remote(classes.size());
  std::printf("# %d stations per class, %.1f days at 1 Hz, seeds from %llu (+50 per class)\n", seeds, days,
              static_cast<unsigned long long>(first));
  for (std::size_t i = 0; i < classes.size(); ++i) {
    const auto at = std::find(names.begin(), names.end(), classes[i]);
    if (at == names.end()) {
      mic::disturbance_class(classes[i], 0, days);  // throws, naming the known classes
    }
    const std::uint64_t base = first + 50 * static_cast<std::uint64_t>(at - names.begin());
    for (int k = 0; k < seeds; ++k) run_station(classes[i], base + static_cast<std::uint64_t>(k), days, pair[i], remote[i]);
  }
  std::printf("\n| class | stations | pair-only coverage, halves' spread not added | pair-only coverage | widened "
              "| unflagged coverage | flagged (not vouched for) | events seen | pair scale error | pair angle error "
              "| remote coverage | remote scale error | remote angle error | remote refused |\n"
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  Tally all_pair, all_remote;
  for (std::size_t i = 0; i < classes.size(); ++i) {
    print_row(classes[i], pair[i], remote[i]);
    all_pair.add(pair[i]);
    all_remote.add(remote[i]);
  }
  print_row("all", all_pair, all_remote);
  return 0;
}
