// The jackknife's sums (src/core/estimation/robust_sections.hpp, GroupedNormalEquations): the
// sums of every group but one, made from per-group sums, equal the weighted sums over the cells
// outside that group (the jackknife's refit) to rounding: for sections and for interleaved
// groups, with the reference's noise to correct for, and on a remote's instruments.
#include "magnetometer_insitu_calibration/estimation/errors_in_variables.hpp"
#include "../../../src/core/estimation/robust_sections.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace mic = magnetometer_insitu_calibration;
namespace robust = magnetometer_insitu_calibration::detail::robust;

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
  remote.remote = true;
  remote.noise = &noise;  // ignored on a remote's instruments
  for (const robust::Regression* regression : {&least_squares, &corrected, &remote}) {
    // Sections.
    std::vector<int> group(cells.size());
    for (std::size_t i = 0; i < cells.size(); ++i) group[i] = cells[i].section;
    const robust::GroupedNormalEquations by_section(cells, weight, *regression, group, 6);
    for (std::size_t s = 0; s < 6; ++s) {
      expect_equal_sums(by_section.without(s),
                        robust::weighted_normal_equations(cells, weight, *regression, static_cast<int>(s)), "section");
      double section_weight = 0.0;
      for (std::size_t i = 0; i < cells.size(); ++i) section_weight += cells[i].section == static_cast<int>(s) ? weight[i] : 0.0;
      EXPECT_NEAR(by_section.weight(s), section_weight, 1e-12 * section_weight);
    }
    // Interleaved groups: the group's cells given weight 0 instead.
    for (std::size_t i = 0; i < cells.size(); ++i) group[i] = static_cast<int>(i % 5);
    const robust::GroupedNormalEquations interleaved(cells, weight, *regression, group, 5);
    for (std::size_t g = 0; g < 5; ++g) {
      std::vector<double> others = weight;
      for (std::size_t i = g; i < cells.size(); i += 5) others[i] = 0.0;
      expect_equal_sums(interleaved.without(g), robust::weighted_normal_equations(cells, others, *regression, -1),
                        "interleaved");
    }
  }
  // The correction's noise term is there to be compared.
  EXPECT_GT(robust::weighted_normal_equations(cells, weight, corrected, -1).given_noise.norm(), 0.0);
}
