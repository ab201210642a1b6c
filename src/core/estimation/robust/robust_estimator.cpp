// Robust frequency-domain estimator, steps 1-6 in order (see robust_estimator.hpp); its pieces:
// residual_screen.cpp (1), section_irls.cpp (3, 5), weighted_eiv_solve.cpp (5),
// robust_covariance.cpp and section_jackknife.cpp (6), remote_cells.cpp (the remote),
// halves_split.cpp (without a remote). The per-window dispatcher is in ../window_estimator.cpp.
#include "magnetometer_insitu_calibration/estimation/robust/robust_estimator.hpp"

#include "magnetometer_insitu_calibration/estimation/delay_estimation.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "../delay_spectra.hpp"
#include "../failed_window_estimate.hpp"
#include "../pair_averages.hpp"
#include "halves_split.hpp"
#include "remote_cells.hpp"
#include "robust_covariance.hpp"
#include "section_cells.hpp"
#include "section_irls.hpp"
#include "section_trend.hpp"
#include "weighted_eiv_solve.hpp"
#include "../spectral_tools.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numeric>
#include <optional>
#include <sstream>

namespace magnetometer_insitu_calibration {

using namespace detail::robust;

/// What is kept between windows: the section transforms' plans and the plain estimator (its
/// FFTW plan and buffers for the window length).
struct RobustFdEstimator::Impl {
  explicit Impl(const EstimatorSettings& settings) : plain(settings) {}
  detail::RealDft dft;
  FdWlseEstimator plain;
  Readings screened_reference, screened_test;  ///< nT, the records with the masked runs filled
  Readings paired_reference, paired_test;      ///< nT, the records in use averaged in pairs of samples
};

namespace {

/// The records a window is estimated from after step 1, and the Eq. 2 fit on them.
struct ScreenedWindow {
  bool masked = false;  ///< true: the records are Impl's screened_reference / screened_test
  /// Eq. 2 on the records in use, when it was fitted (the trend and the delay's spectra).
  std::optional<WindowEstimate> fit;
  /// True while the plain estimator's last transform is of the records in use.
  bool plain_spectra_current = true;
};

/// The window's sections: K of about section_s each (at least 2 / band_low, so that a section
/// reaches down to band_low with its second harmonic), [first[s], first[s + 1]).
struct SectionLayout {
  double band_low_hz = 0.0, band_high_hz = 0.0;
  std::size_t count = 1;
  std::vector<std::size_t> first;
};

/// The errors-in-variables decision of a window before the solve: the noise to correct for (null
/// for none) and what is reported when it is not applied.
struct EivPlan {
  const ReferenceNoiseModel* noise = nullptr;
  ErrorsInVariables without = ErrorsInVariables::kNoNoiseModel;
};

EivPlan plan_eiv(const RobustSettings& rs, const WindowInputs& inputs) {
  if (!rs.errors_in_variables) return {nullptr, ErrorsInVariables::kOff};
  if (!inputs.reference_noise.has_noise()) return {nullptr, ErrorsInVariables::kNoNoiseModel};
  return {&inputs.reference_noise, ErrorsInVariables::kRefused};
}

}  // namespace

RobustFdEstimator::RobustFdEstimator(EstimatorSettings settings) : settings_(std::move(settings)) {
  settings_.validate();
  impl_ = std::make_unique<Impl>(settings_);
}

RobustFdEstimator::~RobustFdEstimator() = default;

/// One window's estimate, step by step; a fresh one per estimate() call.
class RobustFdEstimator::Window {
 public:
  Window(RobustFdEstimator& owner, const Eigen::Ref<const Readings>& reference_nT,
         const Eigen::Ref<const Readings>& test_nT, double sample_period_s, const WindowInputs& inputs)
      : impl_(*owner.impl_),
        settings_(owner.settings_),
        rs_(owner.settings_.robust),
        diagnostics_(owner.diagnostics_),
        reference_nT_(reference_nT),
        test_nT_(test_nT),
        period_s_(sample_period_s),
        length_(static_cast<std::size_t>(reference_nT.rows())),
        duration_s_(static_cast<double>(length_) * sample_period_s),
        eiv_(plan_eiv(owner.settings_.robust, inputs)),
        inputs_(inputs) {
    regression_.noise = eiv_spectrum();
    regression_.sample_period_s = period_s_;
  }

  WindowEstimate estimate();

 private:
  const Eigen::Ref<const Readings> reference() const {
    return screened_.masked ? Eigen::Ref<const Readings>(impl_.screened_reference) : reference_nT_;
  }
  const Eigen::Ref<const Readings> test() const {
    return screened_.masked ? Eigen::Ref<const Readings>(impl_.screened_test) : test_nT_;
  }
  const NoiseSpectrum* eiv_spectrum() const { return eiv_.noise != nullptr ? &eiv_.noise->spectrum : nullptr; }

  /// Eq. 2 on whole records (fits_on_pairs: on their pair averages, its samples and period
  /// those of the window); the plain estimator's spectra are then the averages'.
  WindowEstimate plain_fit(const Eigen::Ref<const Readings>& reference, const Eigen::Ref<const Readings>& test);
  void use_mask(const std::vector<char>& mask);
  void screen(const WindowEstimate& initial);
  SectionLayout plan_sections();
  std::vector<Cell> section_cells(const Eigen::Ref<const Readings>& reference, const Eigen::Ref<const Readings>& test,
                                  bool with_reference);
  std::size_t assign_scale_bins(std::vector<Cell>& cells) const;
  void choose_instruments(const std::vector<Cell>& cells, WindowEstimate& result);
  void remove_delay(std::vector<Cell>& cells, IrlsResult& fit, std::size_t bins, WindowEstimate& result);
  void compare_with_pair(const std::vector<Cell>& cells, const IrlsResult& fit, double covariance_cells,
                         WindowEstimate& result);
  void finish(const std::vector<Cell>& cells, const IrlsResult& fit, std::size_t bins, WindowEstimate& result);

  Impl& impl_;
  const EstimatorSettings& settings_;
  const RobustSettings& rs_;
  RobustDiagnostics& diagnostics_;
  const Eigen::Ref<const Readings> reference_nT_, test_nT_;
  const double period_s_;
  const std::size_t length_;
  const double duration_s_;
  const EivPlan eiv_;
  const WindowInputs& inputs_;
  ScreenedWindow screened_;
  bool pairs_ = false;  ///< the last plain_fit was on pair averages (Impl::paired_*)
  SectionLayout sections_;
  Regression regression_;  ///< least squares with the EIV plan's noise, or the remote's instruments
};

WindowEstimate RobustFdEstimator::estimate(const Eigen::Ref<const Readings>& reference_nT,
                                           const Eigen::Ref<const Readings>& test_nT, double sample_period_s,
                                           const WindowInputs& inputs) {
  if (reference_nT.rows() != test_nT.rows() || (inputs.remote_nT != nullptr && inputs.remote_nT->rows() != reference_nT.rows())) {
    throw std::invalid_argument("RobustFdEstimator: reference, test and remote have different lengths");
  }
  if (!(sample_period_s > 0.0)) throw std::invalid_argument("RobustFdEstimator: sample period <= 0");
  inputs.reference_noise.validate();
  diagnostics_ = RobustDiagnostics{};
  return Window(*this, reference_nT, test_nT, sample_period_s, inputs).estimate();
}

WindowEstimate RobustFdEstimator::Window::estimate() {
  // Step 1: n0 from Eq. 2 and the residual screen.
  WindowEstimate initial = plain_fit(reference_nT_, test_nT_);
  initial.method = "robust";
  initial.eiv = eiv_.without;
  initial.eiv_noise = inputs_.reference_noise;
  initial.weights = "lambda^gamma x Huber cell x section";
  if (initial.quality == Quality::kNotFinite || initial.quality == Quality::kTooFewSamples || !initial.n.allFinite()) {
    return initial;
  }
  screen(initial);
  // Step 2: sections and cells.
  sections_ = plan_sections();
  std::vector<Cell> cells = section_cells(reference(), test(), true);
  diagnostics_.sections = sections_.count;
  diagnostics_.section_samples = length_ / sections_.count;
  diagnostics_.cells = cells.size();

  WindowEstimate result = initial;  // keeps samples, period, the EIV plan; the rest is overwritten
  result.band_low_hz = sections_.band_low_hz;
  result.band_high_hz = sections_.band_high_hz;
  result.harmonic_first =
      static_cast<int>(std::max(1L, static_cast<long>(std::ceil(sections_.band_low_hz * duration_s_ - 1e-9))));
  result.harmonic_last = static_cast<int>(std::min(std::floor(sections_.band_high_hz * duration_s_ + 1e-9),
                                                   std::floor(0.5 * static_cast<double>(length_ - 1))));  // as the cells
  result.screened_fraction =
      static_cast<double>(std::count(diagnostics_.screened.begin(), diagnostics_.screened.end(), 1)) /
      static_cast<double>(length_);
  if (cells.size() < 8) {
    std::ostringstream text;
    text << "only " << cells.size() << " section harmonics in " << sections_.band_low_hz << "-"
         << sections_.band_high_hz << " Hz";
    return detail::failed_window_estimate(result, Quality::kTooFewSamples, text.str());
  }
  const std::size_t bins = assign_scale_bins(cells);
  result.weights = robust_weights_text(bins);
  choose_instruments(cells, result);
  // Steps 3 and 5: IRLS with the errors-in-variables term, or on the remote's instruments.
  IrlsResult fit = irls(cells, sections_.count, bins, rs_, regression_);
  if (!fit.ok) {
    return detail::failed_window_estimate(result, Quality::kIllConditioned, "weighted A is singular: no signal in the band");
  }
  // Eq. 2 on the screened records, for the trend, unless already fitted; its whole-window
  // transforms are the delay's.
  if (!screened_.fit) {
    screened_.fit = plain_fit(reference(), test());
    screened_.plain_spectra_current = true;
  }
  remove_delay(cells, fit, bins, result);  // step 4
  diagnostics_.section_weights = fit.section_weight;
  diagnostics_.iterations = fit.iterations;
  // The last step with the final weights frozen, so that n, the sandwich and the jackknife all
  // belong to the same weighted estimating equation.
  {
    const WeightedSolution last = solve_frozen(cells, fit.weight, regression_);
    if (last.ok) static_cast<WeightedSolution&>(fit) = last;
  }
  finish(cells, fit, bins, result);  // step 6, trend, quality
  return result;
}

WindowEstimate RobustFdEstimator::Window::plain_fit(const Eigen::Ref<const Readings>& reference,
                                                    const Eigen::Ref<const Readings>& test) {
  pairs_ = detail::fits_on_pairs(length_, period_s_, settings_);
  if (!pairs_) return impl_.plain.estimate(reference, test, period_s_);
  detail::average_pairs(reference, impl_.paired_reference);
  detail::average_pairs(test, impl_.paired_test);
  WindowEstimate e = impl_.plain.estimate(impl_.paired_reference, impl_.paired_test, 2.0 * period_s_);
  e.samples = length_;
  e.sample_period_s = period_s_;
  return e;
}

void RobustFdEstimator::Window::use_mask(const std::vector<char>& mask) {
  screened_.masked = std::find(mask.begin(), mask.end(), 1) != mask.end();
  screened_.plain_spectra_current = false;
  if (!screened_.masked) return;
  impl_.screened_reference = reference_nT_;
  impl_.screened_test = test_nT_;
  detail::fill_masked(impl_.screened_reference, impl_.screened_test, mask);
}

/// Step 1, two passes: the mask of n0's residual, then of n0 re-estimated on the cleaned
/// records. The screened records depend only on the mask, and the mask only on n0: a pass whose
/// mask or n0 is the previous one's is not computed again. Nothing masked: the input records
/// themselves are used, not a copy.
void RobustFdEstimator::Window::screen(const WindowEstimate& initial) {
  diagnostics_.screened.assign(length_, 0);
  screened_.fit = initial;  // Eq. 2 on the records as they are
  if (!rs_.screen) return;
  std::vector<char> mask = screen_residual(reference_nT_, test_nT_, initial.n, period_s_, rs_);
  use_mask(mask);
  if (screened_.masked) screened_.fit = plain_fit(impl_.screened_reference, impl_.screened_test);
  screened_.plain_spectra_current = true;  // of the screened records, or no mask: of the records themselves
  const Eigen::Matrix3d n0 = screened_.fit->n.allFinite() ? screened_.fit->n : initial.n;
  if (n0 != initial.n) {
    std::vector<char> second = screen_residual(reference_nT_, test_nT_, n0, period_s_, rs_);
    if (second != mask) {
      use_mask(second);
      if (screened_.masked) {
        screened_.fit.reset();
      } else {
        screened_.fit = initial;
      }
      mask = std::move(second);
    }
  }
  diagnostics_.screened = std::move(mask);
}

/// The band (configured, or chosen from the coherence of the cleaned records) and the sections.
SectionLayout RobustFdEstimator::Window::plan_sections() {
  SectionLayout layout;
  layout.band_low_hz = settings_.band_low_hz;
  layout.band_high_hz = settings_.band_high_hz;
  if (rs_.auto_band) {
    BandSelectionSettings bs;
    bs.search_low_hz = rs_.band_search_low_hz;
    bs.search_high_hz = rs_.band_search_high_hz;
    bs.min_coherence = rs_.min_band_coherence;
    bs.min_band_harmonics = settings_.min_harmonics;
    diagnostics_.band = select_band(reference(), test(), period_s_, bs);
    if (diagnostics_.band.ok) {
      layout.band_low_hz = diagnostics_.band.low_hz;
      layout.band_high_hz = diagnostics_.band.high_hz;
    }
  }
  const double section_s = std::max(rs_.section_s, 2.0 / layout.band_low_hz);  // s
  layout.count = std::max<std::size_t>(1, static_cast<std::size_t>(std::floor(duration_s_ / section_s + 1e-9)));
  layout.first.resize(layout.count + 1);
  for (std::size_t s = 0; s <= layout.count; ++s) layout.first[s] = length_ * s / layout.count;
  return layout;
}

/// The cells of the records, section by section: each section detrended, transformed, its band
/// harmonics made cells, its trend column projected out. After a delay is removed (step 4) only
/// the test's spectra are new: with_reference false leaves x zero and transforms the test alone.
std::vector<Cell> RobustFdEstimator::Window::section_cells(const Eigen::Ref<const Readings>& reference,
                                                           const Eigen::Ref<const Readings>& test, bool with_reference) {
  // Columns 0-2 the reference, 3-5 the test, 6-8 the remote (with the reference, when given).
  const int first_column = with_reference ? 0 : 3;
  const int end_column = with_reference && inputs_.remote_nT != nullptr ? 9 : 6;
  std::vector<Cell> cells;
  std::vector<Eigen::VectorXcd> spectra(9);
  for (std::size_t s = 0; s < sections_.count; ++s) {
    const std::size_t first = sections_.first[s], count = sections_.first[s + 1] - first;
    const double section_duration = static_cast<double>(count) * period_s_;
    const long j0 = std::max(1L, static_cast<long>(std::ceil(sections_.band_low_hz * section_duration - 1e-9)));
    const long j1 = std::min(static_cast<long>(std::floor(sections_.band_high_hz * section_duration + 1e-9)),
                             static_cast<long>((count - 1) / 2));
    // Each column's least-squares line (as detrend() fits it), subtracted on the way into the
    // transform's input; only the bins up to j1 are copied out.
    const double* columns[9] = {};
    for (int c = 0; c < end_column; ++c) {
      const Eigen::Ref<const Readings> record = c < 3 ? reference : (c < 6 ? test : Eigen::Ref<const Readings>(*inputs_.remote_nT));
      columns[c] = record.col(c % 3).data() + first;
    }
    double mean[9] = {}, slope[9] = {};
    if (count < 2) {  // as detrend(): a lone sample becomes 0
      for (int c = 0; c < end_column; ++c) mean[c] = count == 1 ? columns[c][0] : 0.0;
    } else if (with_reference) {
      detail::fit_lines<6>(columns, count, mean, slope);
      if (end_column == 9) detail::fit_lines<3>(columns + 6, count, mean + 6, slope + 6);
    } else {
      detail::fit_lines<3>(columns + 3, count, mean + 3, slope + 3);  // column by column: as in the 6
    }
    for (int c = first_column; c < end_column; ++c) {
      detail::subtract_line(columns[c], count, mean[c], slope[c], impl_.dft.input(count));
      impl_.dft.execute(count, static_cast<std::size_t>(std::max(j1, 0L)) + 1, spectra[static_cast<std::size_t>(c)]);
    }
    const std::size_t section_begin = cells.size();
    for (long j = j0; j <= j1; ++j) {
      Cell cell;
      cell.section = static_cast<int>(s);
      cell.frequency_hz = static_cast<double>(j) / section_duration;
      cell.harmonic = j;
      cell.g = std::pow(2.0 * M_PI * static_cast<double>(j) / static_cast<double>(count), settings_.gamma);
      cell.length = count;
      for (int k = 0; k < 3; ++k) {
        cell.x(k) = with_reference ? spectra[static_cast<std::size_t>(k)](j) : std::complex<double>(0.0, 0.0);
        cell.y(k) = spectra[static_cast<std::size_t>(k + 3)](j);
        if (end_column == 9) cell.z(k) = spectra[static_cast<std::size_t>(k + 6)](j);
      }
      cells.push_back(cell);
    }
    if (rs_.section_trend) remove_section_trend(cells, section_begin, cells.size(), end_column == 9);
  }
  return cells;
}

/// Scale bins: the cells in frequency order, groups of at least max(40, 3K) cells. Returns the
/// number of bins.
std::size_t RobustFdEstimator::Window::assign_scale_bins(std::vector<Cell>& cells) const {
  std::vector<std::size_t> order(cells.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return cells[a].frequency_hz < cells[b].frequency_hz; });
  const std::size_t per_bin = std::max<std::size_t>(40, 3 * sections_.count);
  const std::size_t bins = std::max<std::size_t>(1, cells.size() / per_bin);
  for (std::size_t r = 0; r < order.size(); ++r) cells[order[r]].bin = static_cast<int>(std::min(bins - 1, r / per_bin));
  return static_cast<std::size_t>(
      1 + std::max_element(cells.begin(), cells.end(), [](const Cell& a, const Cell& b) { return a.bin < b.bin; })->bin);
}

/// Step 4: the delay from the cleaned records with n and, when significant (> 2 se) and
/// correct_delay, the test advanced by it over the whole window and cut into the same sections
/// (same cells, same bins), then step 3 again. A phase shift of each section's own DFT would take
/// its ends' wrap-around for data (advance_record).
void RobustFdEstimator::Window::remove_delay(std::vector<Cell>& cells, IrlsResult& fit, std::size_t bins,
                                             WindowEstimate& result) {
  if (!rs_.estimate_delay) return;
  DelaySettings ds;
  ds.low_hz = std::max(sections_.band_low_hz, 2.0 / duration_s_);
  ds.high_hz = std::max(rs_.delay_max_hz, 2.0 * ds.low_hz);
  const Eigen::Ref<const Readings> r = reference(), t = test();
  try {
    detail::WholeWindowSpectra whole;
    const Eigen::Ref<const Readings> spectra_r = pairs_ ? Eigen::Ref<const Readings>(impl_.paired_reference) : r;
    const Eigen::Ref<const Readings> spectra_t = pairs_ ? Eigen::Ref<const Readings>(impl_.paired_test) : t;
    whole.length = static_cast<std::size_t>(spectra_r.rows());
    for (int c = 0; c < 6; ++c) {
      whole.bins[static_cast<std::size_t>(c)] = impl_.plain.last_spectrum(c);
      whole.ends[static_cast<std::size_t>(c)] = detail::column_ends(c < 3 ? spectra_r.col(c) : spectra_t.col(c - 3));
    }
    const bool have_spectra = screened_.plain_spectra_current &&
                              std::all_of(whole.bins.begin(), whole.bins.end(), [](const auto* b) { return b != nullptr; });
    diagnostics_.delay = have_spectra ? detail::estimate_delay_from_spectra(whole, fit.n, pairs_ ? 2.0 * period_s_ : period_s_, ds)
                                      : estimate_delay(r, t, fit.n, period_s_, ds);
  } catch (const InputError&) {
    diagnostics_.delay = DelayEstimate{};
  }
  const DelayEstimate& d = diagnostics_.delay;
  if (!d.ok) return;
  result.delay_s = d.delay_s;
  result.delay_ci95_s = d.ci95_s;
  if (!rs_.correct_delay || !(std::abs(d.delay_s) > 2.0 * d.stderr_s)) return;
  std::vector<Cell> aligned = cells;
  {
    const std::vector<Cell> shifted = section_cells(r, advance_record(t, period_s_, d.delay_s), false);
    for (std::size_t i = 0; i < aligned.size(); ++i) aligned[i].y = shifted[i].y;
  }
  IrlsResult again = irls(aligned, sections_.count, bins, rs_, regression_);
  if (!again.ok) return;  // the cells and fit without the correction stay
  fit = std::move(again);
  cells = std::move(aligned);
  diagnostics_.delay_corrected = true;
}

/// Step 6 (robust_covariance.cpp), the trend and the quality rules.
void RobustFdEstimator::Window::finish(const std::vector<Cell>& cells, const IrlsResult& fit, std::size_t bins,
                                       WindowEstimate& result) {
  diagnostics_.eiv_applied = fit.eiv_applied;
  diagnostics_.eiv_noise = fit.noise;
  diagnostics_.n_uncorrected = fit.n_uncorrected;
  result.eiv = regression_.on_remote() ? ErrorsInVariables::kRemoteReference
                                  : (fit.eiv_applied ? ErrorsInVariables::kApplied : eiv_.without);
  Regression as_solved = regression_;  // the jackknife refits as n was solved
  if (!fit.eiv_applied) as_solved.noise = nullptr;
  const CellCovariance cov =
      cell_covariance(cells, fit, sections_.count, bins, fit.eiv_applied ? eiv_.noise : nullptr, as_solved);
  diagnostics_.covariance_sandwich = cov.sandwich;
  diagnostics_.covariance_jackknife = cov.jackknife.covariance;
  diagnostics_.jackknife_sections = cov.jackknife.sections;
  diagnostics_.jackknife_frequency_groups = cov.jackknife.frequency_groups;
  diagnostics_.covariance_noise_levels = cov.level_term;
  result.n = fit.n;
  result.n_covariance = cov.covariance;
  result.covariance_dof = cov.cells;
  result.intervals = cov.intervals;
  result.parameters = decompose(result.n, result.n_covariance, result.covariance_dof);
  result.downweighted_fraction = cov.downweighted_fraction;
  // Trend (test frame, nT/day): the trend column of Eq. 2 on the screened records, with its
  // sandwich standard error. The sections are detrended one by one, so the robust fit itself
  // has no single trend; the screened records no longer hold the transients that would bias it.
  result.trend_nT_per_day = screened_.fit->trend_nT_per_day;
  result.trend_stderr_nT_per_day = screened_.fit->trend_stderr_nT_per_day;
  // Quality figures, as for Eq. 2 but over the weighted cells.
  result.coherence = cov.coherence;
  result.residual_rms_nT = cov.residual_rms_nT;
  // The condition of the reference's own weighted sums (the IV sums are not symmetric).
  apply_quality_rules(result, weighted_normal_equations(cells, fit.weight, Regression{}).a,
                      static_cast<long>(cells.size()), "section harmonics", settings_);
  if (regression_.on_remote()) {
    compare_with_pair(cells, fit, cov.cells, result);
  } else {
    result.band_split = band_split_check(cells, fit, sections_.count, bins, fit.eiv_applied ? eiv_.noise : nullptr,
                                         as_solved);
    widen_by_halves_spread(result);
    result.local_events = check_local_events(reference(), test(), period_s_, sections_.band_high_hz, result.delay_s);
  }
}

/// With a remote: the instrumental-variable regression when the remote predicts every direction
/// of the local reference strongly enough over the cells (remote_reference.hpp), else least
/// squares on the pair, the refusal stated.
void RobustFdEstimator::Window::choose_instruments(const std::vector<Cell>& cells, WindowEstimate& result) {
  RemoteReference& remote = result.remote;
  remote.given = inputs_.remote_nT != nullptr;
  if (!remote.given) return;
  const std::string name = inputs_.remote_name.empty() ? std::string("the remote") : inputs_.remote_name;
  assess_cells_remote_strength(remote, cells, std::vector<double>(cells.size(), 1.0));
  std::ostringstream text;
  text.precision(3);
  if (!(remote.strength >= kMinRemoteStrength)) {
    text << "remote " << name << " refused: it predicts the local reference too weakly (first-stage F "
         << remote.strength << " < " << kMinRemoteStrength << ", smallest canonical coherence "
         << remote.canonical_coherence << "; coherence x/y/z " << remote.coherence(0) << "/" << remote.coherence(1)
         << "/" << remote.coherence(2) << "): a different field or a wrong time base; n from the pair alone";
    remote.text = text.str();
    return;
  }
  remote.used = true;
  regression_.instruments = Regression::Instruments::kRemote;
  text << "remote reference " << name;
  remote.text = text.str();
}

/// The remote's strength over the final weights, and the pair-only estimate on the same cells
/// and weights against n (remote_reference.hpp).
void RobustFdEstimator::Window::compare_with_pair(const std::vector<Cell>& cells, const IrlsResult& fit,
                                                  double covariance_cells, WindowEstimate& result) {
  RemoteReference& remote = result.remote;
  assess_cells_remote_strength(remote, cells, fit.weight);
  std::ostringstream text;
  text.precision(3);
  text << " (first-stage F " << remote.strength << ", coherence x/y/z " << remote.coherence(0) << "/"
       << remote.coherence(1) << "/" << remote.coherence(2) << ")";
  remote.text += text.str();
  Regression pair;
  pair.noise = eiv_spectrum();
  pair.sample_period_s = period_s_;
  assess_cells_pair_difference(remote, cells, fit, sections_.count, pair, regression_, eiv_.noise, covariance_cells);
}

}  // namespace magnetometer_insitu_calibration
