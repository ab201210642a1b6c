// The robust estimator's sections (src/core/estimation/robust/: section_cells.hpp and its neighbours):
//  - the per-section trend column (section_trend.hpp): the ramp's DFT is what FFTW computes, its
//    projection removes a ramp and is idempotent, and it keeps the intervals of 6-hour windows
//    honest when one pier tilts (a 1/f^2 random walk seen by the test sensor only), which a
//    time-domain detrend of each section alone does not;
//  - the jackknife's sums (GroupedNormalEquations): the sums of every group but one, made from
//    per-group sums, equal the weighted sums over the cells outside that group (the jackknife's
//    refit) to rounding: for sections and for interleaved groups, with the reference's noise to
//    correct for, and on a remote's instruments.
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "magnetometer_insitu_calibration/estimation/errors_in_variables.hpp"
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/estimation/robust/robust_estimator.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "magnetometer_insitu_calibration/simulation/unmodelled_disturbances.hpp"
#include "../../../src/core/estimation/robust/section_jackknife.hpp"
#include "../../../src/core/estimation/robust/weighted_eiv_solve.hpp"
#include "../../../src/core/estimation/robust/section_trend.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <random>
#include <vector>

namespace mic = magnetometer_insitu_calibration;
namespace robust = magnetometer_insitu_calibration::detail::robust;

TEST(SectionTrend, RampDftIsTheDftOfTheRamp) {
  for (std::size_t length : {97u, 100u}) {
    for (long j = 1; j < static_cast<long>(length); j += 7) {
      std::complex<double> direct(0.0, 0.0);
      for (std::size_t t = 0; t < length; ++t)
        direct += static_cast<double>(t) * std::polar(1.0, -2.0 * M_PI * static_cast<double>(j) * static_cast<double>(t) /
                                                              static_cast<double>(length));
      EXPECT_LT(std::abs(robust::ramp_dft(j, length) - direct), 1e-9 * static_cast<double>(length)) << length << " " << j;
    }
  }
}

TEST(SectionTrend, RemovesTheRampAndIsIdempotent) {
  const std::size_t length = 1000;
  std::vector<robust::Cell> cells;
  for (long j = 3; j <= 60; ++j) {
    robust::Cell c;
    c.harmonic = j;
    c.length = length;
    c.g = 2.0 * M_PI * static_cast<double>(j) / static_cast<double>(length);
    const std::complex<double> r = robust::ramp_dft(j, length);
    const std::complex<double> other(std::cos(0.7 * static_cast<double>(j)), std::sin(1.3 * static_cast<double>(j)));
    c.x << 2.5 * r, -0.5 * r + other, other;
    c.y << 0.0, r, 3.0 * other;
    cells.push_back(c);
  }
  const std::vector<robust::Cell> before = cells;
  robust::remove_section_trend(cells, 0, cells.size());
  for (const robust::Cell& c : cells) {
    EXPECT_LT(std::abs(c.x(0)), 1e-12 * std::abs(robust::ramp_dft(c.harmonic, length)));  // a pure ramp: nothing left
    EXPECT_EQ(c.y(0), std::complex<double>(0.0, 0.0));  // zero stays zero
  }
  // What is left of each column is orthogonal to the ramp in Eq. 2's inner product.
  for (int k = 0; k < 3; ++k) {
    double dot = 0.0, norm = 0.0;
    for (const robust::Cell& c : cells) {
      dot += c.g * (std::conj(robust::ramp_dft(c.harmonic, length)) * c.x(k)).real();
      norm += c.g * std::norm(robust::ramp_dft(c.harmonic, length)) ;
    }
    EXPECT_LT(std::abs(dot), 1e-12 * norm) << k;
  }
  std::vector<robust::Cell> twice = cells;
  robust::remove_section_trend(twice, 0, twice.size());
  for (std::size_t i = 0; i < cells.size(); ++i) {
    EXPECT_LT((twice[i].x - cells[i].x).norm(), 1e-12 * before[i].x.norm());
    EXPECT_LT((twice[i].y - cells[i].y).norm(), 1e-12 * before[i].y.norm() + 1e-300);
  }
}

namespace {

/// rms over 6-hour windows of (estimate - truth) / (ci95 / interval_quantile), scale ratios and
/// non-orthogonalities, for days of a station whose test pier tilts.
double rms_z_of_six_hour_windows(bool section_trend, int days) {
  double sum = 0.0;
  int count = 0;
  for (int d = 0; d < days; ++d) {
    mic::SimulationSettings s;
    s.seed = 7100 + static_cast<std::uint64_t>(d);
    s.variation_z_ratio = 0.2;
    s.keep_clean_field = false;
    mic::SimulatedPair pair = mic::simulate_pair(s);
    mic::UnmodelledDisturbanceSettings u;
    u.seed = s.seed;
    u.tilt_walk_nT_per_sqrt_day = 0.27;  // monte_carlo_unmodelled's disturbed station
    mic::add_unmodelled_disturbances(pair, u);
    const mic::CalibrationParameters truth = mic::decompose(pair.n_true);
    mic::EstimatorSettings es;
    es.robust.section_trend = section_trend;
    mic::WindowEstimator estimator(es);
    for (Eigen::Index first = 0; first + 21600 <= pair.reference.values_nT.rows(); first += 21600) {
      const mic::WindowEstimate e = estimator.estimate(pair.reference.values_nT.middleRows(first, 21600),
                                                       pair.test.values_nT.middleRows(first, 21600), 1.0);
      for (int k = 0; k < 3; ++k) {
        const double zs = (e.parameters.scale_ratio(k) - truth.scale_ratio(k)) /
                          (e.parameters.scale_ratio_ci95(k) / e.parameters.interval_quantile);
        const double za = (e.parameters.nonorthogonality_deg(k) - truth.nonorthogonality_deg(k)) /
                          (e.parameters.nonorthogonality_ci95_deg(k) / e.parameters.interval_quantile);
        sum += zs * zs + za * za;
        count += 2;
      }
    }
  }
  return std::sqrt(sum / count);
}

}  // namespace

TEST(SectionTrend, KeepsSixHourIntervalsHonestWhenOnePierTilts) {
  const double with = rms_z_of_six_hour_windows(true, 16), without = rms_z_of_six_hour_windows(false, 16);
  std::printf("6-hour windows, test pier tilting: errors %.2f standard errors rms with the section trend, %.2f without\n",
              with, without);
  // Measured (16 days, 64 windows, 384 errors): 1.21 with, 1.40 without. Without any tilt the
  // same windows are near 1 either way (monte_carlo_unmodelled, docs/validation.md).
  EXPECT_LT(with, 1.3);
  EXPECT_GT(without, 1.1 * with);
}

namespace {

/// Cells of `sections` sections with random spectra (nT), a tenth of them rejected (weight 0).
std::vector<robust::Cell> random_cells(std::size_t sections, std::vector<double>& weight) {
  std::mt19937_64 random(5);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<robust::Cell> cells;
  weight.clear();
  const std::size_t length = 21600;
  for (std::size_t s = 0; s < sections; ++s) {
    for (long j = 5; j <= 216; ++j) {
      robust::Cell c;
      c.section = static_cast<int>(s);
      c.harmonic = j;
      c.length = length;
      c.frequency_hz = static_cast<double>(j) / static_cast<double>(length);
      c.g = std::pow(2.0 * M_PI * static_cast<double>(j) / static_cast<double>(length), 1.0);
      for (int k = 0; k < 3; ++k) {
        c.x(k) = {1e3 * normal(random), 1e3 * normal(random)};
        c.y(k) = 1.01 * c.x(k) + std::complex<double>(10.0 * normal(random), 10.0 * normal(random));
        c.z(k) = 0.8 * c.x((k + 1) % 3) + std::complex<double>(100.0 * normal(random), 100.0 * normal(random));
      }
      cells.push_back(c);
      weight.push_back(uniform(random) < 0.1 ? 0.0 : uniform(random));
    }
  }
  return cells;
}

void expect_equal_sums(const robust::NormalEquations& got, const robust::NormalEquations& want, const char* what) {
  EXPECT_LE((got.a - want.a).norm(), 1e-12 * want.a.norm()) << what;
  EXPECT_LE((got.c - want.c).norm(), 1e-12 * want.c.norm()) << what;
  EXPECT_LE((got.given_noise - want.given_noise).norm(), 1e-12 * std::max(want.given_noise.norm(), 1e-300)) << what;
  EXPECT_EQ(got.instrumental, want.instrumental) << what;
}

}  // namespace

TEST(SectionJackknife, SumsWithoutAGroupAreTheSumsOverTheOtherCells) {
  std::vector<double> weight;
  const std::vector<robust::Cell> cells = random_cells(6, weight);
  const mic::NoiseSpectrum noise = mic::NoiseSpectrum::fluxgate_figure(10.0);
  robust::Regression least_squares, corrected, remote;
  corrected.noise = &noise;
  remote.instruments = robust::Regression::Instruments::kRemote;
  remote.noise = &noise;  // ignored on a remote's instruments
  for (const robust::Regression* regression : {&least_squares, &corrected, &remote}) {
    // Sections: the section's cells given weight 0 instead.
    const std::vector<int> sections = robust::section_groups(cells);
    const robust::GroupedNormalEquations by_section(cells, weight, *regression, sections, 6);
    for (std::size_t s = 0; s < 6; ++s) {
      std::vector<double> others = weight;
      double section_weight = 0.0;
      for (std::size_t i = 0; i < cells.size(); ++i) {
        if (cells[i].section != static_cast<int>(s)) continue;
        section_weight += weight[i];
        others[i] = 0.0;
      }
      expect_equal_sums(by_section.without(s), robust::weighted_normal_equations(cells, others, *regression), "section");
      EXPECT_NEAR(by_section.weight(s), section_weight, 1e-12 * section_weight);
    }
    // Interleaved frequency groups: each holds a fifth of the cells, spread over the whole band.
    const std::vector<int> interleaved_group = robust::interleaved_frequency_groups(cells, 5);
    const robust::GroupedNormalEquations interleaved(cells, weight, *regression, interleaved_group, 5);
    for (std::size_t g = 0; g < 5; ++g) {
      std::vector<double> others = weight;
      std::size_t members = 0;
      double lowest = 1e9, highest = 0.0;
      for (std::size_t i = 0; i < cells.size(); ++i) {
        if (interleaved_group[i] != static_cast<int>(g)) continue;
        others[i] = 0.0;
        ++members;
        lowest = std::min(lowest, cells[i].frequency_hz);
        highest = std::max(highest, cells[i].frequency_hz);
      }
      EXPECT_NEAR(static_cast<double>(members), static_cast<double>(cells.size()) / 5.0, 1.0) << g;
      EXPECT_LT(lowest, 7.0 / 21600.0) << g;   // the band is harmonics 5-216 of 21600 s
      EXPECT_GT(highest, 214.0 / 21600.0) << g;
      expect_equal_sums(interleaved.without(g), robust::weighted_normal_equations(cells, others, *regression),
                        "interleaved");
    }
  }
  // The correction's noise term is there to be compared.
  EXPECT_GT(robust::weighted_normal_equations(cells, weight, corrected).given_noise.norm(), 0.0);
}
