// How often does the report's agreement check (estimation/window_agreement.hpp) call the windows
// of one record disagreeing? On simulated records of one constant n it is the false alarm rate
// (at most 2 x 0.01 if the windows' intervals are honest); with the test's z scale stepped by
// STEP % halfway through the record, the rate of detection. The default pipeline and plain Eq. 2
// on the same records (`calibrate_records --intervals K`). A program, not a test; figures in
// docs/estimator_validation.md B22.
//
//   monte_carlo_window_agreement [seeds=200] [days=1] [intervals=4] [step_pct=0] [first_seed=14000]
//
// Records: the simulator's defaults (a quiet station, equal noise in both instruments) of `days`
// days at 1 Hz. The step multiplies the test's z variations about their mean from the middle
// sample on, so that the second half's z scale ratio is (1 + step) times the first's.
//
// Also printed: the calibration node's change check (estimation/calibration_change.hpp) between
// each pair of consecutive windows, at the node's default false-alarm probability 1e-3: the share
// of pairs whose joint test is significant (B23).
#include "magnetometer_insitu_calibration/estimation/calibration_change.hpp"
#include "magnetometer_insitu_calibration/estimation/window_agreement.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

struct Rates {
  int records = 0, assessed = 0, disagree = 0, joint_below_5pct = 0, named_scale_z = 0;
  int parameters = 0, parameter_below_5pct = 0;
  double sum_joint_chi2_per_dof = 0.0;
  int change_pairs = 0, change_significant = 0;  // consecutive windows, the node's change check
  int change_significant_chi2 = 0;                // the same chi2 against chi2's tail (before B23)
};

/// The node's change check between consecutive disjoint windows, at its default 1e-3.
void tally_changes(const std::vector<mic::WindowEstimate>& windows, Rates& r) {
  const mic::CalibrationChangeSettings settings;  // false_alarm_probability 1e-3
  for (std::size_t i = 1; i < windows.size(); ++i) {
    const mic::CalibrationChange c = mic::check_calibration_change(windows[i - 1], windows[i], settings);
    if (c.status == mic::CalibrationChangeStatus::kInconclusive) continue;
    ++r.change_pairs;
    r.change_significant += c.p_value < settings.false_alarm_probability;
    r.change_significant_chi2 += mic::chi2_tail_probability(c.chi2, 9) < settings.false_alarm_probability;
  }
}

void tally(const mic::WindowAgreement& a, Rates& r) {
  ++r.records;
  if (!a.assessed) return;
  ++r.assessed;
  r.disagree += !a.agree;
  r.joint_below_5pct += a.joint_p_value < 0.05;
  r.sum_joint_chi2_per_dof += a.joint_chi2 / a.joint_dof;
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
  const char* names[2] = {"default", "plain Eq. 2"};
  Rates rates[2];
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k < seeds; ++k) {
    mic::SimulationSettings s;
    s.seed = first_seed + static_cast<unsigned long long>(k);
    s.duration_s = days * 86400.0;
    s.keep_clean_field = false;
    mic::SimulatedPair pair = mic::simulate_pair(s);
    if (step_pct != 0.0) {
      auto z = pair.test.values_nT.col(2);
      const double mean = z.mean();
      for (Eigen::Index i = z.size() / 2; i < z.size(); ++i) z(i) = mean + (z(i) - mean) * (1.0 + step_pct / 100.0);
    }
    for (int m = 0; m < 2; ++m) {
      mic::CalibrationSettings settings;
      settings.windows.intervals = intervals;
      if (m == 1) {  // as calibrate_records --method plain
        settings.estimator.method = mic::EstimatorMethod::kPlain;
        settings.response_model = false;
      }
      const mic::PairCalibration result = mic::calibrate_records(pair.reference, pair.test, settings);
      const std::vector<mic::WindowEstimate> disjoint = mic::disjoint_window_estimates(result.windows);
      const mic::WindowAgreement a = mic::check_window_agreement(disjoint);
      tally(a, rates[m]);
      tally_changes(disjoint, rates[m]);
      std::printf("seed %llu %s: %s\n", static_cast<unsigned long long>(s.seed), names[m], a.text.c_str());
    }
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf(
      "\n# %d records of %.2f days, %d intervals, z scale step %+.2f %% at the middle, seeds %llu-%llu, %.0f s\n",
      seeds, days, intervals, step_pct, first_seed, first_seed + seeds - 1, seconds);
  std::printf(
      "| estimator | called disagreeing | of those, naming scale z | joint p < 0.05 | parameters with p < 0.05 | mean "
      "joint chi2/dof | change check, consecutive windows at 1e-3 (chi2's tail) |\n|---|---|---|---|---|---|---|\n");
  for (int m = 0; m < 2; ++m) {
    const Rates& r = rates[m];
    const double n = r.assessed > 0 ? r.assessed : 1;
    std::printf("| %s | %.1f %% (%d of %d) | %d | %.1f %% | %.1f %% | %.2f | %.2f %% (%d of %d; %.2f %%) |\n", names[m],
                100.0 * r.disagree / n, r.disagree, r.assessed, r.named_scale_z, 100.0 * r.joint_below_5pct / n,
                100.0 * r.parameter_below_5pct / (r.parameters > 0 ? r.parameters : 1), r.sum_joint_chi2_per_dof / n,
                100.0 * r.change_significant / (r.change_pairs > 0 ? r.change_pairs : 1), r.change_significant,
                r.change_pairs, 100.0 * r.change_significant_chi2 / (r.change_pairs > 0 ? r.change_pairs : 1));
  }
  return 0;
}
