// How often does the report's agreement check (estimation/window_agreement.hpp) call the windows
// of one record disagreeing? On simulated records of one constant n it is the false alarm rate
// (at most 2 x 0.01 if the windows' intervals are honest); with the test's z scale stepped by
// STEP % halfway through the record, the rate of detection. The default pipeline and plain Eq. 2
// on the same records (`calibrate_records --intervals K`). A program, not a test; figures in
// docs/validation.md ("Window agreement and change check").
//
//   monte_carlo_window_agreement [seeds=200] [days=1] [intervals=4] [step_pct=0] [first_seed=14000]
//
// Records: the simulator's defaults (a quiet station, equal noise in both instruments) of `days`
// days at 1 Hz; MC_STATION=disturbed, the disturbed station of monte_carlo_unmodelled (traffic,
// spikes, gaps, a tilting test pier, heater, response mismatch; unmodelled_scenario.hpp). The
// step multiplies the test's z variations about their mean from the middle sample on, so that the
// second half's z scale ratio is (1 + step) times the first's.
//
// Also printed: the calibration node's change check (estimation/calibration_change.hpp) between
// each pair of consecutive windows, at the node's default false-alarm probability 1e-3: the share
// of pairs it calls significant (the joint test deciding only from 36 cells, the parameters
// below), and in brackets the share whose joint test alone is (Hotelling's T^2 with the windows'
// cells, whatever their number), and that chi2 against chi2's own tail (the covariances taken as
// known). And as the node checks, the first window against each window of the second half: with
// a step, the share of those detected.
#include "magnetometer_insitu_calibration/estimation/calibration_change.hpp"
#include "magnetometer_insitu_calibration/estimation/window_agreement.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "unmodelled_scenario.hpp"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <algorithm>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

struct Rates {
  int records = 0, assessed = 0, disagree = 0, joint_below_5pct = 0, named_scale_z = 0;
  int parameters = 0, parameter_below_5pct = 0;
  double sum_joint_chi2_per_dof = 0.0, sum_joint_chi2_per_expected = 0.0, sum_fewest_cells = 0.0;
  int joint_tested = 0;
  // The joint test's rejections at 0.05 and 0.01 by the fewest cells of a record's windows.
  static constexpr int kBuckets = 6;
  static constexpr double kBucketTop[kBuckets] = {18.0, 27.0, 36.0, 54.0, 90.0, 1e300};
  int bucket_records[kBuckets] = {}, bucket_below_5pct[kBuckets] = {}, bucket_below_1pct[kBuckets] = {};
  int change_pairs = 0, change_significant = 0;  // consecutive windows, the node's change check
  int change_significant_chi2 = 0;                // the same chi2 against chi2's tail (covariances known)
  int change_significant_joint = 0;               // the joint test alone, whatever the cells
  int late_pairs = 0, late_significant = 0, late_significant_joint = 0;  // first window against the second half's
};

/// The node's change check between consecutive disjoint windows, at its default 1e-3.
void tally_changes(const std::vector<mic::WindowEstimate>& windows, Rates& r) {
  const mic::CalibrationChangeSettings settings;  // false_alarm_probability 1e-3
  for (std::size_t i = 1; i < windows.size(); ++i) {
    const mic::CalibrationChange c = mic::check_calibration_change(windows[i - 1], windows[i], settings);
    if (c.status == mic::CalibrationChangeStatus::kInconclusive) continue;
    ++r.change_pairs;
    r.change_significant += c.significant;
    r.change_significant_joint += c.p_value < settings.false_alarm_probability;
    r.change_significant_chi2 += mic::chi2_tail_probability(c.chi2, 9) < settings.false_alarm_probability;
  }
  // As the node checks: the first window accepted, each window of the record's second half (after
  // the step, when there is one) against it.
  for (std::size_t i = windows.size() / 2; i < windows.size() && windows.size() > 1; ++i) {
    const mic::CalibrationChange c = mic::check_calibration_change(windows.front(), windows[i], settings);
    if (c.status == mic::CalibrationChangeStatus::kInconclusive) continue;
    ++r.late_pairs;
    r.late_significant += c.significant;
    r.late_significant_joint += c.p_value < settings.false_alarm_probability;
  }
}

void tally(const mic::WindowAgreement& a, Rates& r) {
  ++r.records;
  if (!a.assessed) return;
  ++r.assessed;
  r.disagree += !a.agree;
  r.joint_below_5pct += a.joint_p_value < 0.05;
  r.sum_joint_chi2_per_dof += a.joint_chi2 / a.joint_dof;
  r.sum_joint_chi2_per_expected += a.joint_chi2 / a.joint_expected_chi2;
  r.joint_tested += a.joint_tested;
  int largest = 0;
  for (int k = 0; k < 9; ++k) {
    ++r.parameters;
    r.parameter_below_5pct += a.parameters[k].p_value < 0.05;
    if (a.parameters[k].birge_ratio > a.parameters[largest].birge_ratio) largest = k;
  }
  r.named_scale_z += !a.agree && largest == 2;
}

}  // namespace

int main(int argc, char** argv) {
  const int seeds = argc > 1 ? std::atoi(argv[1]) : 200;
  const double days = argc > 2 ? std::atof(argv[2]) : 1.0;
  const int intervals = argc > 3 ? std::atoi(argv[3]) : 4;
  const double step_pct = argc > 4 ? std::atof(argv[4]) : 0.0;
  const unsigned long long first_seed = argc > 5 ? std::strtoull(argv[5], nullptr, 10) : 14000ULL;
  if (seeds < 1 || !(days > 0.0) || intervals < 2) {
    std::fprintf(stderr,
                 "usage: monte_carlo_window_agreement [seeds>=1] [days>0] [intervals>=2] [step_pct] [first_seed]\n");
    return 2;
  }
  const char* station_env = std::getenv("MC_STATION");
  const std::string station = station_env != nullptr ? station_env : "quiet";
  if (station != "quiet" && station != "disturbed" && station != "filter") {
    std::fprintf(stderr, "MC_STATION: quiet, disturbed or filter (unmodelled_scenario.hpp), not '%s'\n",
                 station.c_str());
    return 2;
  }
  const char* names[2] = {"default", "plain Eq. 2"};
  Rates rates[2];
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k < seeds; ++k) {
    const unsigned long long seed = first_seed + static_cast<unsigned long long>(k);
    mic::SimulatedPair pair = monte_carlo::station_records(station, seed, days);
    if (step_pct != 0.0) {
      auto z = pair.test.values_nT.col(2);
      const double mean = z.mean();
      for (Eigen::Index i = z.size() / 2; i < z.size(); ++i) z(i) = mean + (z(i) - mean) * (1.0 + step_pct / 100.0);
    }
    for (int m = 0; m < 2; ++m) {
      mic::CalibrationSettings settings;
      settings.windows.intervals = intervals;
      if (m == 1) {  // as calibrate_records --method plain
        settings.window.estimator.method = mic::EstimatorMethod::kPlain;
        settings.window.response_model = false;
      }
      const mic::PairCalibration result = mic::calibrate_records(pair.reference, pair.test, settings);
      const std::vector<mic::WindowEstimate> disjoint = mic::disjoint_window_estimates(result.windows);
      const mic::WindowAgreement a = mic::check_window_agreement(disjoint);
      tally(a, rates[m]);
      double fewest = std::numeric_limits<double>::infinity();
      for (const mic::WindowEstimate& w : disjoint) fewest = std::min(fewest, w.covariance_dof);
      rates[m].sum_fewest_cells += fewest;
      if (a.assessed) {
        int b = 0;
        while (fewest >= Rates::kBucketTop[b]) ++b;
        ++rates[m].bucket_records[b];
        rates[m].bucket_below_5pct[b] += a.joint_p_value < 0.05;
        rates[m].bucket_below_1pct[b] += a.joint_p_value < 0.01;
      }
      tally_changes(disjoint, rates[m]);
      std::printf("seed %llu %s: %s\n", seed, names[m], a.text.c_str());
    }
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf(
      "\n# %d records of %.2f days of a %s station, %d intervals, z scale step %+.2f %% at the middle, "
      "seeds %llu-%llu, "
      "%.0f s\n",
      seeds, days, station.c_str(), intervals, step_pct, first_seed, first_seed + seeds - 1, seconds);
  std::printf(
      "| estimator | called disagreeing | of those, naming scale z | joint p < 0.05 | parameters with p < 0.05 | mean "
      "joint chi2/dof | change check, consecutive windows at 1e-3 (joint test alone; chi2's tail) |\n"
      "|---|---|---|---|---|---|---|\n");
  for (int m = 0; m < 2; ++m) {
    const Rates& r = rates[m];
    const double n = r.assessed > 0 ? r.assessed : 1;
    const double pairs = r.change_pairs > 0 ? r.change_pairs : 1;
    std::printf("| %s | %.1f %% (%d of %d) | %d | %.1f %% | %.1f %% | %.2f | %.2f %% (%d of %d; %.2f %%; %.2f %%) |\n",
                names[m],
                100.0 * r.disagree / n, r.disagree, r.assessed, r.named_scale_z, 100.0 * r.joint_below_5pct / n,
                100.0 * r.parameter_below_5pct / (r.parameters > 0 ? r.parameters : 1), r.sum_joint_chi2_per_dof / n,
                100.0 * r.change_significant / pairs, r.change_significant, r.change_pairs,
                100.0 * r.change_significant_joint / pairs, 100.0 * r.change_significant_chi2 / pairs);
  }
  std::printf(
      "\n| estimator | joint chi2 / its expected value (T^2) | joint test decided | fewest cells of a window (mean) "
      "|\n|---|---|---|---|\n");
  for (int m = 0; m < 2; ++m) {
    const Rates& r = rates[m];
    const double n = r.assessed > 0 ? r.assessed : 1;
    std::printf("| %s | %.3f | %.1f %% | %.1f |\n", names[m], r.sum_joint_chi2_per_expected / n,
                100.0 * r.joint_tested / n, r.sum_fewest_cells / (r.records > 0 ? r.records : 1));
  }
  std::printf("\n| estimator | fewest cells of a record's windows: records, joint p < 0.05, p < 0.01 |\n|---|---|\n");
  for (int m = 0; m < 2; ++m) {
    std::printf("| %s |", names[m]);
    double low = 0.0;
    for (int b = 0; b < Rates::kBuckets; ++b) {
      const Rates& r = rates[m];
      if (r.bucket_records[b] > 0)
        std::printf(" [%.0f, %s): %d, %.1f %%, %.1f %%;", low,
                    b + 1 < Rates::kBuckets ? std::to_string(static_cast<int>(Rates::kBucketTop[b])).c_str() : "inf",
                    r.bucket_records[b],
                    100.0 * r.bucket_below_5pct[b] / r.bucket_records[b],
                    100.0 * r.bucket_below_1pct[b] / r.bucket_records[b]);
      low = Rates::kBucketTop[b];
    }
    std::printf(" |\n");
  }
  std::printf(
      "\n| estimator | first window against each of the second half's, at 1e-3 (joint test alone) |\n|---|---|\n");
  for (int m = 0; m < 2; ++m) {
    const Rates& r = rates[m];
    const double pairs = r.late_pairs > 0 ? r.late_pairs : 1;
    std::printf("| %s | %.2f %% (%d of %d; %.2f %%) |\n", names[m], 100.0 * r.late_significant / pairs,
                r.late_significant, r.late_pairs, 100.0 * r.late_significant_joint / pairs);
  }
  return 0;
}
