// Held-out real records: one instrument pair recorded on several days, each day calibrated on
// its own (four 6-hour quarters and the whole day, as `calibrate_records --intervals 4`), by
// several estimators on the same records. Nothing about the instruments changes between the
// days, so where the intervals are honest:
//  - the quarters of each day scatter around their weighted mean as their intervals say
//    (sqrt(chi2 / 3) per parameter; the aim is <= 1.3 on WIC 2025-05-14);
//  - the whole-day estimates of two days differ by about their combined standard error:
//    z = (day_b - day_a) / sqrt(se_a^2 + se_b^2) per parameter, about N(0, 1).
// A program, not a test: the second WIC day is not shipped (docs/validation.md, "Real WIC days",
// says where it comes from); nothing in the estimator was chosen on it.
//
//   real_days_agreement REF_DAY1 TEST_DAY1 REF_DAY2 TEST_DAY2 [REF_DAY3 TEST_DAY3 ...]
//
// Files in any format `calibrate_records` reads (IAGA-2002, MagPy CDF, ...). Parameters: the
// scale ratios x, y, z (H, E, Z for WIC) and the non-orthogonalities xy, xz, yz (deg).
#include "window_agreement.hpp"

#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"

#include <array>
#include <cmath>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

namespace mic = magnetometer_insitu_calibration;
using monte_carlo::quarters_scatter;
using monte_carlo::six_parameters;
using Six = monte_carlo::SixParameters;

namespace {

struct Estimator {
  const char* name;
  mic::CalibrationSettings settings;
};

std::vector<Estimator> estimators() {
  std::vector<Estimator> list;
  mic::CalibrationSettings s;
  s.windows.intervals = 4;
  list.push_back({"default (the reference's noise from the pair)", s});
  mic::CalibrationSettings plain = s;
  plain.window.estimator.method = mic::EstimatorMethod::kPlain;
  list.push_back({"plain Eq. 2", plain});
  mic::CalibrationSettings none = s;
  none.window.pair_noise = false;
  list.push_back({"default, --no-pair-noise (no EIV correction)", none});
  // The LEMI-036's data-sheet figure, 10 pT/sqrt(Hz), read two ways (docs/validation.md, "How to
  // read a maker's noise figure"): as a flat ASD (rms per 1 s sample = ASD / sqrt(2 dt)) and as
  // 1/f at 1 Hz (`--reference-noise-pT 10`); given as the reference's noise figure.
  mic::CalibrationSettings flat = s;
  flat.window.reference_noise_figure.white_nT.setConstant(0.010 / std::sqrt(2.0));
  list.push_back({"default, maker's 10 pT/sqrt(Hz) read flat", flat});
  mic::CalibrationSettings pink = s;
  pink.window.reference_noise_figure = mic::NoiseSpectrum::fluxgate_figure(10.0);
  list.push_back({"default, maker's 10 pT/sqrt(Hz) read as 1/f (--reference-noise-pT 10)", pink});
  return list;
}

void print_row(const char* label, const std::array<double, 6>& v, const char* format) {
  std::printf("  %-34s", label);
  for (double x : v) std::printf(format, x);
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 5 || (argc - 1) % 2 != 0) {
    std::fprintf(stderr, "usage: real_days_agreement REF_DAY1 TEST_DAY1 REF_DAY2 TEST_DAY2 [REF TEST ...]\n");
    return 2;
  }
  try {
    std::vector<std::pair<mic::VectorRecord, mic::VectorRecord>> days;
    for (int a = 1; a + 1 < argc; a += 2) days.emplace_back(mic::read_record(argv[a]), mic::read_record(argv[a + 1]));
    std::printf("# parameters: scale x y z, non-orthogonality xy xz yz (deg)\n");
    for (const Estimator& e : estimators()) {
      std::printf("\n## %s\n", e.name);
      std::vector<Six> whole;
      double z_sq = 0.0;
      int z_count = 0;
      for (std::size_t d = 0; d < days.size(); ++d) {
        const mic::PairCalibration result = mic::calibrate_records(days[d].first, days[d].second, e.settings);
        whole.push_back(six_parameters(result.windows.back()));
        const std::string tag = "day " + std::to_string(d + 1) + " " + mic::format_iso8601(result.windows.back().start_s).substr(0, 10);
        print_row((tag + ": value").c_str(), whole.back().value, " %10.5f");
        print_row("  ci95", [&] {
          std::array<double, 6> c{};
          for (int k = 0; k < 6; ++k) c[k] = whole.back().ci95(k);
          return c;
        }(), " %10.5f");
        print_row("  quarters' sqrt(chi2/3)", quarters_scatter(result.windows), " %10.2f");
        std::printf("  EIV: %s\n", result.windows.back().estimate.eiv_text().c_str());
      }
      for (std::size_t a = 0; a < whole.size(); ++a)
        for (std::size_t b = a + 1; b < whole.size(); ++b) {
          std::array<double, 6> z{};
          for (int k = 0; k < 6; ++k) {
            z[k] = (whole[b].value[k] - whole[a].value[k]) / std::hypot(whole[a].se[k], whole[b].se[k]);
            z_sq += z[k] * z[k];
            ++z_count;
          }
          const std::string label = "day " + std::to_string(b + 1) + " - day " + std::to_string(a + 1) + ", z";
          print_row(label.c_str(), z, " %+10.2f");
        }
      std::printf("  rms z over the day pairs and parameters: %.2f (%d values)\n", std::sqrt(z_sq / z_count), z_count);
    }
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "real_days_agreement: %s\n", ex.what());
    return 1;
  }
  return 0;
}
