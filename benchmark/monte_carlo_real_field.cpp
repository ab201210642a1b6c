// Known truth on a real field (a program, not a test). A real record, an observatory's reference
// day, is taken as the field B: its bursts and quiet hours, its weak or strong vertical, and its
// own instrument noise, which both simulated instruments then see alike. Two simulated
// instruments record it,
//   R = B + noise_r,   T = B n + d + noise_t,
// with the simulator's n (the paper's scale ratios, angles of 0.01-0.3 deg) and noise figures
// (each instrument its own: 0.01 nT white per sample and 0.005 nT/sqrt(Hz) 1/f at 1 Hz). Only the
// noise changes from seed to seed, so what is measured is how the intervals cover on this
// field, which the simulator's stationary power-law field may flatter; nothing about the real
// instruments (their response, a Z that drifts) enters.
//
//   monte_carlo_real_field FILE [--seeds N] [--first-seed S] [--window SEC]
//
// FILE: any record calibrate_records reads (IAGA-2002, MagPy CDF, ...), at 1 s. --window: windows
// of SEC seconds every SEC seconds (default: the whole record as one window). Prints, per
// estimator (the default and plain Eq. 2) over every window of every seed: the coverage of the
// nine parameters by each window's 95 % interval, the scale error (per window the largest of the
// three scale-ratio errors) and the angle error (the largest of the three non-orthogonalities and
// three misalignments), median / 95th percentile, and the windows flagged.
#include "parameter_errors.hpp"
#include "percentile.hpp"

#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/simulation/power_law_noise.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

const Eigen::RowVector3d kOffsetNT(-95.0, 80.0, 400.0);  // the test's offset, nT (any)

struct Options {
  std::string file;
  int seeds = 100;
  unsigned first_seed = 60000;
  double window_s = 0.0;  // 0: the whole record
};

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--seeds" && has_value) o.seeds = std::atoi(argv[++i]);
    else if (a == "--first-seed" && has_value) o.first_seed = static_cast<unsigned>(std::atol(argv[++i]));
    else if (a == "--window" && has_value) o.window_s = std::atof(argv[++i]);
    else if (o.file.empty() && a.rfind("--", 0) != 0) o.file = a;
    else throw std::invalid_argument("unknown or incomplete option '" + a + "'");
  }
  if (o.file.empty() || o.seeds < 1 || o.window_s < 0.0) {
    throw std::invalid_argument("usage: monte_carlo_real_field FILE [--seeds N] [--first-seed S] [--window SEC]");
  }
  return o;
}

struct Tally {
  const char* name;
  mic::CalibrationSettings settings;
  int windows = 0, flagged = 0, covered = 0;
  std::vector<double> scale_errors, angle_errors;  // %, deg
  std::vector<int> covered_by_window;              // the window's position in the record
  std::vector<std::string> labels;

  void add(std::size_t position, const mic::CalibrationWindow& w, const Eigen::Matrix3d& truth) {
    ++windows;
    if (covered_by_window.size() <= position) {
      covered_by_window.resize(position + 1, 0);
      labels.resize(position + 1);
    }
    labels[position] = w.label + " (" + mic::format_iso8601(w.start_s, 0) + ")";
    if (w.estimate.quality != mic::Quality::kOk) {
      ++flagged;
      return;
    }
    const monte_carlo::ParameterErrors e = monte_carlo::parameter_errors(w.estimate.parameters, truth);
    covered += e.covered;
    covered_by_window[position] += e.covered;
    scale_errors.push_back(e.scale_pct);
    angle_errors.push_back(e.angle_deg);
  }

  void print() const {
    const int ok = windows - flagged;
    std::printf("| %s | %.3f / %.3f %% | %.4f / %.4f deg | %.1f %% | %d of %d |\n", name,
                percentile(scale_errors, 0.5), percentile(scale_errors, 0.95), percentile(angle_errors, 0.5),
                percentile(angle_errors, 0.95), ok > 0 ? 100.0 * covered / (9.0 * ok) : NAN, flagged, windows);
  }

  /// The window whose parameters were covered least often over the seeds (flagged ones count as missed).
  void print_worst_window(int seeds) const {
    if (covered_by_window.size() < 2) return;
    std::size_t worst = 0;
    for (std::size_t i = 1; i < covered_by_window.size(); ++i) {
      if (covered_by_window[i] < covered_by_window[worst]) worst = i;
    }
    std::printf("%s: least covered window %s, %.1f %% of its 9 x %d parameters\n", name, labels[worst].c_str(),
                100.0 * covered_by_window[worst] / (9.0 * seeds), seeds);
  }
};

}  // namespace

int main(int argc, char** argv) {
  try {
    const Options o = parse(argc, argv);
    const mic::VectorRecord field = mic::read_record(o.file);
    const double period_s = mic::median_sample_period(field);
    const mic::SimulationSettings simulator;  // its n and its instruments' noise figures
    const Eigen::Matrix3d n_true = simulator.n_true();

    std::vector<Tally> tallies;
    mic::CalibrationSettings s;
    if (o.window_s > 0.0) {
      s.windows.window_s = o.window_s;
      s.windows.step_s = o.window_s;
    }
    tallies.push_back({"default", s, 0, 0, 0, {}, {}});
    s.window.estimator.method = mic::EstimatorMethod::kPlain;
    tallies.push_back({"plain Eq. 2", s, 0, 0, 0, {}, {}});

    mic::SpectralSynthesizer synth(field.size());
    for (int k = 0; k < o.seeds; ++k) {
      mic::SimulationRng rng(o.first_seed + static_cast<unsigned>(k));
      mic::VectorRecord reference = field, test = field;
      test.values_nT = (field.values_nT * n_true).rowwise() + kOffsetNT;
      mic::add_instrument_noise(reference.values_nT, simulator.reference_white_nT,
                                simulator.reference_pink_nT_per_sqrt_hz, period_s, rng, synth);
      mic::add_instrument_noise(test.values_nT, simulator.test_white_nT, simulator.test_pink_nT_per_sqrt_hz, period_s,
                                rng, synth);
      test.source = "simulated test";
      for (Tally& t : tallies) {
        const std::vector<mic::CalibrationWindow> windows = mic::calibrate_records(reference, test, t.settings).windows;
        for (std::size_t i = 0; i < windows.size(); ++i) t.add(i, windows[i], n_true);
      }
    }
    std::printf("%s: %zu samples at %g s; %d noise seeds from %u; ", o.file.c_str(), field.size(), period_s, o.seeds,
                o.first_seed);
    if (o.window_s > 0.0) std::printf("windows of %g s\n", o.window_s);
    else std::printf("the whole record as one window\n");
    std::printf("| estimator | scale error, median / 95th pct | angle error, median / 95th pct | coverage (9 parameters) "
                "| windows flagged |\n|---|---|---|---|---|\n");
    for (const Tally& t : tallies) t.print();
    for (const Tally& t : tallies) t.print_worst_window(o.seeds);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "monte_carlo_real_field: %s\n", e.what());
    return 1;
  }
}
