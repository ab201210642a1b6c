// Robust frequency-domain estimator, steps 1-6 in order (see robust_estimator.hpp); its pieces:
// residual_screen.cpp (1), section_irls.cpp (3, 5), weighted_eiv_solve.cpp (5),
// section_jackknife.cpp (6b, 6c). The per-window dispatcher is in window_estimator.cpp.
#include "magnetometer_insitu_calibration/estimation/robust_estimator.hpp"

#include "magnetometer_insitu_calibration/estimation/delay_estimation.hpp"
#include "magnetometer_insitu_calibration/estimation/errors_in_variables.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "delay_spectra.hpp"
#include "failed_window_estimate.hpp"
#include "robust_sections.hpp"
#include "sandwich_cells.hpp"
#include "section_trend.hpp"
#include "spectral_tools.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numeric>
#include <optional>
#include <sstream>

namespace magnetometer_insitu_calibration {

using namespace detail::robust;

namespace {

/// What the errors-in-variables step used (WindowEstimate::eiv), `applied` from the solve.
std::string eiv_text(const RobustSettings& rs, bool applied) {
  std::ostringstream text;
  switch (rs.eiv) {
    case EivCorrection::kNone:
      return "none (off)";
    case EivCorrection::kGiven:
      if (!rs.reference_noise_identified()) return "none (noise not identified)";
      if (!applied) return "none (given noise as large as the signal: refused)";
      text << "given reference noise: white " << rs.reference_white_nT.maxCoeff() * 1000.0 << " pT rms, 1/f "
           << rs.reference_pink_nT_per_sqrt_hz.maxCoeff() * 1000.0 << " pT/sqrt(Hz) at 1 Hz";
      if (!rs.reference_noise_source.empty()) text << " (" << rs.reference_noise_source << ")";
      return text.str();
    case EivCorrection::kNoiseRatio:
      if (!applied) return "none (ratio correction refused)";
      text << "ratio " << rs.eiv_noise_ratio << " (share of the residual, as asked)";
      return text.str();
  }
  return "unknown";
}

}  // namespace

/// What is kept between windows: the section transforms' plans and the plain estimator (its
/// FFTW plan and buffers for the window length).
struct RobustFdEstimator::Impl {
  explicit Impl(const EstimatorSettings& settings) : plain(settings) {}
  detail::RealDft dft;
  FdWlseEstimator plain;
  Readings screened_reference, screened_test;  ///< nT, the records with the masked runs filled
  std::vector<double> section_columns[6];       ///< nT, one section's six columns, detrended
};

RobustFdEstimator::RobustFdEstimator(EstimatorSettings settings) : settings_(std::move(settings)) {
  settings_.validate();
  impl_ = std::make_unique<Impl>(settings_);
}

RobustFdEstimator::~RobustFdEstimator() = default;

WindowEstimate RobustFdEstimator::estimate(const Eigen::Ref<const Readings>& reference_nT,
                                           const Eigen::Ref<const Readings>& test_nT, double sample_period_s) {
  if (reference_nT.rows() != test_nT.rows()) {
    throw std::invalid_argument("RobustFdEstimator: reference and test have different lengths");
  }
  if (!(sample_period_s > 0.0)) throw std::invalid_argument("RobustFdEstimator: sample period <= 0");
  const RobustSettings& rs = settings_.robust;
  diagnostics_ = RobustDiagnostics{};
  const std::size_t length = static_cast<std::size_t>(reference_nT.rows());
  const double duration_s = static_cast<double>(length) * sample_period_s;

  // Step 1: n0 from Eq. 2 and the residual screen (two passes).
  FdWlseEstimator& plain = impl_->plain;
  WindowEstimate initial = plain.estimate(reference_nT, test_nT, sample_period_s);
  initial.method = "robust";
  initial.eiv = eiv_text(rs, false);
  initial.weights = "lambda^gamma x Huber cell x section";
  if (initial.quality == Quality::kNotFinite || initial.quality == Quality::kTooFewSamples ||
      !initial.n.allFinite()) {
    return initial;
  }
  // The screened records depend only on the mask, and the mask only on n0: an estimate whose
  // records or n0 are those of an earlier one is that one, and is not computed again.
  // Nothing masked: the input records themselves are used, not a copy.
  Readings& screened_reference = impl_->screened_reference;
  Readings& screened_test = impl_->screened_test;
  bool masked = false;  // true: the records are screened_reference, screened_test
  // True while the plain estimator's last transform is of the records in use (the delay reads
  // its spectra).
  bool plain_spectra_current = true;
  const auto use_mask = [&](const std::vector<char>& m) {
    masked = std::find(m.begin(), m.end(), 1) != m.end();
    plain_spectra_current = false;
    if (!masked) return;
    screened_reference = reference_nT;
    screened_test = test_nT;
    detail::fill_masked(screened_reference, screened_test, m);
  };
  diagnostics_.screened.assign(length, 0);
  std::optional<WindowEstimate> screened_fit = initial;  // Eq. 2 on the records as they are
  if (rs.screen) {
    std::vector<char> mask = screen_residual(reference_nT, test_nT, initial.n, sample_period_s, rs);
    use_mask(mask);
    if (masked) screened_fit = plain.estimate(screened_reference, screened_test, sample_period_s);
    plain_spectra_current = true;  // of the screened records, or no mask: of the records themselves
    const Eigen::Matrix3d n0 = screened_fit->n.allFinite() ? screened_fit->n : initial.n;
    if (n0 != initial.n) {  // second pass: n0 re-estimated on the cleaned records
      std::vector<char> second = screen_residual(reference_nT, test_nT, n0, sample_period_s, rs);
      if (second != mask) {
        use_mask(second);
        if (masked) {
          screened_fit.reset();
        } else {
          screened_fit = initial;
        }
        mask = std::move(second);
      }
    }
    diagnostics_.screened = std::move(mask);
  }
  const Eigen::Ref<const Readings> reference = masked ? Eigen::Ref<const Readings>(screened_reference) : reference_nT;
  const Eigen::Ref<const Readings> test = masked ? Eigen::Ref<const Readings>(screened_test) : test_nT;
  const std::size_t screened = static_cast<std::size_t>(
      std::count(diagnostics_.screened.begin(), diagnostics_.screened.end(), 1));

  // Band: configured, or chosen from the coherence of the cleaned records.
  double band_low = settings_.band_low_hz, band_high = settings_.band_high_hz;
  if (rs.auto_band) {
    BandSelectionSettings bs;
    bs.search_low_hz = rs.band_search_low_hz;
    bs.search_high_hz = rs.band_search_high_hz;
    bs.min_coherence = rs.min_band_coherence;
    bs.min_band_harmonics = settings_.min_harmonics;
    diagnostics_.band = select_band(reference, test, sample_period_s, bs);
    if (diagnostics_.band.ok) {
      band_low = diagnostics_.band.low_hz;
      band_high = diagnostics_.band.high_hz;
    }
  }

  // Step 2: sections and cells. A section must reach down to band_low with its 2nd harmonic.
  const double section_s = std::max(rs.section_s, 2.0 / band_low);  // s
  const std::size_t k_sections =
      std::max<std::size_t>(1, static_cast<std::size_t>(std::floor(duration_s / section_s + 1e-9)));
  std::vector<std::size_t> section_first(k_sections + 1);
  for (std::size_t s = 0; s <= k_sections; ++s) section_first[s] = length * s / k_sections;
  // The cells of the records, section by section. After a delay is removed (step 4) only the
  // test's spectra are new: with_reference false leaves x zero and transforms the test alone.
  const auto section_cells = [&](const Eigen::Ref<const Readings>& reference, const Eigen::Ref<const Readings>& test,
                                 bool with_reference) {
    const int first_column = with_reference ? 0 : 3;
    std::vector<Cell> cells;
    std::vector<Eigen::VectorXcd> spectra(6);
    for (std::size_t s = 0; s < k_sections; ++s) {
      const std::size_t first = section_first[s], count = section_first[s + 1] - first;
      const double section_duration = static_cast<double>(count) * sample_period_s;
      const long j0 = std::max(1L, static_cast<long>(std::ceil(band_low * section_duration - 1e-9)));
      const long j1 = std::min(static_cast<long>(std::floor(band_high * section_duration + 1e-9)),
                               static_cast<long>((count - 1) / 2));
      double* columns[6] = {};
      for (int c = first_column; c < 6; ++c) {
        std::vector<double>& column = impl_->section_columns[static_cast<std::size_t>(c)];
        column.resize(count);
        const double* from = (c < 3 ? reference : test).col(c % 3).data() + first;
        std::copy(from, from + count, column.begin());
        columns[c] = column.data();
      }
      if (with_reference) {
        detail::detrend_columns<6>(columns, count);
      } else {
        detail::detrend_columns<3>(columns + 3, count);  // column by column: the same as in the 6
      }
      for (int c = first_column; c < 6; ++c) {  // only the bins up to j1 are copied out
        std::copy(columns[c], columns[c] + count, impl_->dft.input(count));
        impl_->dft.execute(count, static_cast<std::size_t>(std::max(j1, 0L)) + 1, spectra[static_cast<std::size_t>(c)]);
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
        }
        cells.push_back(cell);
      }
      if (rs.section_trend) remove_section_trend(cells, section_begin, cells.size());
    }
    return cells;
  };
  std::vector<Cell> cells = section_cells(reference, test, true);
  diagnostics_.sections = k_sections;
  diagnostics_.section_samples = length / k_sections;
  diagnostics_.cells = cells.size();

  WindowEstimate result = initial;  // keeps samples, period; everything else is overwritten
  result.method = "robust";
  result.eiv = eiv_text(rs, false);
  result.weights = "lambda^gamma x Huber cell x section";
  result.band_low_hz = band_low;
  result.band_high_hz = band_high;
  result.harmonic_first = static_cast<int>(std::max(1L, static_cast<long>(std::ceil(band_low * duration_s - 1e-9))));
  result.harmonic_last = static_cast<int>(std::floor(band_high * duration_s + 1e-9));
  result.screened_fraction = static_cast<double>(screened) / static_cast<double>(length);
  if (cells.size() < 8) {
    std::ostringstream text;
    text << "only " << cells.size() << " section harmonics in " << band_low << "-" << band_high << " Hz";
    return detail::failed_window_estimate(result, Quality::kTooFewSamples, text.str());
  }
  // Scale bins: cells in frequency order, groups of at least max(40, 3K) cells.
  {
    std::vector<std::size_t> order(cells.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return cells[a].frequency_hz < cells[b].frequency_hz; });
    const std::size_t per_bin = std::max<std::size_t>(40, 3 * k_sections);
    const std::size_t bins = std::max<std::size_t>(1, cells.size() / per_bin);
    for (std::size_t r = 0; r < order.size(); ++r) cells[order[r]].bin = static_cast<int>(std::min(bins - 1, r / per_bin));
  }
  const std::size_t bins = static_cast<std::size_t>(
      1 + std::max_element(cells.begin(), cells.end(), [](const Cell& a, const Cell& b) { return a.bin < b.bin; })->bin);
  result.weights = robust_weights_text(bins);

  IrlsResult fit = irls(cells, k_sections, bins, rs, sample_period_s);
  if (!fit.ok) {
    return detail::failed_window_estimate(result, Quality::kIllConditioned, "weighted A is singular: no signal in the band");
  }

  // Eq. 2 on the screened records, for the trend below, unless already fitted; its whole-window
  // transforms are the delay's.
  if (!screened_fit) {
    screened_fit = plain.estimate(reference, test, sample_period_s);
    plain_spectra_current = true;
  }

  // Step 4: delay, and its removal when significant.
  if (rs.estimate_delay) {
    DelaySettings ds;
    ds.low_hz = std::max(band_low, 2.0 / duration_s);
    ds.high_hz = std::max(rs.delay_max_hz, 2.0 * ds.low_hz);
    try {
      const int test_first = plain.settings().trend ? 4 : 3;
      detail::WholeWindowSpectra whole;
      whole.length = length;
      for (int c = 0; c < 6; ++c) {
        whole.bins[static_cast<std::size_t>(c)] = plain.last_spectrum(c < 3 ? c : test_first + c - 3);
        whole.ends[static_cast<std::size_t>(c)] = detail::column_ends(c < 3 ? reference.col(c) : test.col(c - 3));
      }
      const bool have_spectra = plain_spectra_current &&
                                std::all_of(whole.bins.begin(), whole.bins.end(), [](const auto* b) { return b != nullptr; });
      diagnostics_.delay = have_spectra ? detail::estimate_delay_from_spectra(whole, fit.n, sample_period_s, ds)
                                        : estimate_delay(reference, test, fit.n, sample_period_s, ds);
    } catch (const InputError&) {
      diagnostics_.delay = DelayEstimate{};
    }
    const DelayEstimate& d = diagnostics_.delay;
    if (d.ok) {
      result.delay_s = d.delay_s;
      result.delay_ci95_s = d.ci95_s;
      if (rs.correct_delay && std::abs(d.delay_s) > 2.0 * d.stderr_s) {
        // The test advanced by the delay over the whole window, then cut into the same sections
        // (same cells, same bins): a phase shift of each section's own DFT would take its ends'
        // wrap-around for data (advance_record).
        std::vector<Cell> aligned = cells;
        {
          const std::vector<Cell> shifted =
              section_cells(reference, advance_record(test, sample_period_s, d.delay_s), false);
          for (std::size_t i = 0; i < aligned.size(); ++i) aligned[i].y = shifted[i].y;
        }
        IrlsResult again = irls(aligned, k_sections, bins, rs, sample_period_s);
        if (again.ok) {  // else the cells and fit without the correction stay
          fit = std::move(again);
          cells = std::move(aligned);
          diagnostics_.delay_corrected = true;
        }
      }
    }
  }
  diagnostics_.section_weights = fit.section_weight;
  diagnostics_.iterations = fit.iterations;

  // Last IRLS step with the final weights frozen (and, in ratio mode, the EIV fixed point
  // iterated to convergence), so that n, the sandwich and the jackknife below all belong to the
  // same weighted estimating equation.
  {
    const WeightedSolution last = solve_frozen(cells, fit.weight, fit.scale2, rs, sample_period_s, -1, fit.n);
    if (last.ok) static_cast<WeightedSolution&>(fit) = last;
  }
  diagnostics_.eiv_applied = fit.eiv_applied;
  result.eiv = eiv_text(rs, fit.eiv_applied);
  diagnostics_.eiv_noise = fit.noise;
  diagnostics_.n_uncorrected = fit.n_uncorrected;

  // Step 6a: sandwich covariance with the final weights.
  NoiseSpectrum given;
  given.white_nT = rs.reference_white_nT;
  given.pink_nT_per_sqrt_hz = rs.reference_pink_nT_per_sqrt_hz;
  const double share = reference_share_of_residual(rs.eiv_noise_ratio);
  std::vector<Eigen::Vector3d> scale2(bins, Eigen::Vector3d::Zero());
  {
    std::vector<std::vector<double>> per_bin(bins * 3);
    for (const Cell& cell : cells) {
      const Eigen::Vector3d e2 = (cell.y - fit.n.transpose() * cell.x).cwiseAbs2();
      for (int l = 0; l < 3; ++l) per_bin[static_cast<std::size_t>(cell.bin) * 3 + static_cast<std::size_t>(l)].push_back(e2(l));
    }
    for (std::size_t b = 0; b < bins; ++b)
      for (int l = 0; l < 3; ++l) scale2[b](l) = detail::median(per_bin[b * 3 + static_cast<std::size_t>(l)]) / kLn2;
  }
  Eigen::Matrix<double, 9, 9> omega = Eigen::Matrix<double, 9, 9>::Zero();
  Eigen::Matrix<double, 9, 1> score;
  Eigen::Vector3d residual_power = Eigen::Vector3d::Zero(), test_power = Eigen::Vector3d::Zero();
  Eigen::Vector3d inband_variance = Eigen::Vector3d::Zero();
  double weight_sum = 0.0, weight_max_sum = 0.0;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const Cell& cell = cells[i];
    const double w = fit.weight[i];
    weight_max_sum += 1.0;
    weight_sum += w;
    const Eigen::Vector3cd e = cell.y - fit.n.transpose() * cell.x;
    const double wg = w * cell.g;
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    if (fit.eiv_applied) {
      d = rs.eiv == EivCorrection::kGiven
              ? given.expected_periodogram(cell.frequency_hz, sample_period_s, cell.length)
              : ratio_noise_power(e.cwiseAbs2(), scale2[static_cast<std::size_t>(cell.bin)], share);
    }
    for (int l = 0; l < 3; ++l) {
      score.segment<3>(3 * l) = wg * ((cell.x * std::conj(e(l))).real() + d.cwiseProduct(fit.n.col(l)));
    }
    omega.noalias() += score * score.transpose();
    residual_power += w * e.cwiseAbs2();
    test_power += w * cell.y.cwiseAbs2();
    const double l2 = static_cast<double>(cell.length) * static_cast<double>(cell.length);
    inband_variance += (2.0 / l2) * e.cwiseAbs2() / static_cast<double>(k_sections);
  }
  const double effective = std::max(weight_sum, 4.0);
  {  // the cells behind the sandwich, as many as share it equally (sandwich_cells.hpp)
    detail::SandwichCells sandwich_cells(3);
    auto sigma2 = [&](const Cell& cell) { return scale2[static_cast<std::size_t>(cell.bin)]; };
    for (std::size_t i = 0; i < cells.size(); ++i)
      sandwich_cells.add(cells[i].x, fit.weight[i] * cells[i].g, sigma2(cells[i]));
    for (std::size_t i = 0; i < cells.size(); ++i)
      sandwich_cells.share(cells[i].x, fit.weight[i] * cells[i].g, sigma2(cells[i]));
    // No count when a column's residual power is zero in every bin (noise-free records): then the
    // cells themselves.
    const double count = sandwich_cells.count();
    result.covariance_dof = std::isfinite(count) ? count : weight_sum;
  }
  const double dof_correction = 2.0 * effective / (2.0 * effective - 3.0);
  Eigen::Matrix<double, 9, 9> bread = Eigen::Matrix<double, 9, 9>::Zero();
  for (int l = 0; l < 3; ++l) bread.block<3, 3>(3 * l, 3 * l) = fit.a_inverse;
  const Eigen::Matrix<double, 9, 9> cov_col = dof_correction * bread * omega * bread.transpose();
  Matrix9d sandwich;
  for (int r = 0; r < 9; ++r) {
    for (int q = 0; q < 9; ++q) {
      // n(k, l) sits at 3 l + k in vec_col(n) and at 3 k + l in row-major vec(n).
      sandwich(r, q) = cov_col(3 * (r % 3) + r / 3, 3 * (q % 3) + q / 3);
    }
  }

  // Step 6b: delete-one-section jackknife of vec(n) with the same final weights.
  // Too few sections for their own jackknife: interleaved frequency groups instead.
  JackknifeResult jack = section_jackknife(cells, fit, k_sections, rs, sample_period_s);
  if (jack.sections < kMinJackknifeSections) {
    jack = frequency_group_jackknife(cells, fit, kFrequencyGroups, rs, sample_period_s);
  }
  diagnostics_.covariance_sandwich = sandwich;
  diagnostics_.covariance_jackknife = jack.covariance;
  diagnostics_.jackknife_sections = jack.sections;
  diagnostics_.jackknife_frequency_groups = jack.frequency_groups;
  result.n = fit.n;
  result.n_covariance = combine_covariances(sandwich, jack);
  result.intervals = jack.usable() ? "sandwich raised to the jackknife over " + std::to_string(jack.sections) +
                                         (jack.frequency_groups ? " interleaved frequency groups" : " sections")
                                   : std::string("sandwich (no jackknife: too few groups with weight, or one held the "
                                                 "whole signal of a direction)");
  // Step 6d: the identified noise's own uncertainty, through the correction (the jackknife
  // re-solves with the same levels, so it does not see it).
  const Matrix9d level_term = noise_level_covariance_term(cells, fit.weight, fit, rs, sample_period_s);
  diagnostics_.covariance_noise_levels = level_term;
  if (!level_term.isZero(0.0)) {
    result.n_covariance += level_term;
    result.intervals += ", plus the identified reference noise's uncertainty";
  }
  result.parameters = decompose(result.n, result.n_covariance, result.covariance_dof);
  result.downweighted_fraction = 1.0 - weight_sum / std::max(weight_max_sum, 1.0);

  // Trend (test frame, nT/day): the trend column of Eq. 2 on the screened records, with its
  // sandwich standard error. The sections are detrended one by one, so the robust fit itself
  // has no single trend; the screened records no longer hold the transients that would bias it.
  {
    const WindowEstimate& trend_fit = *screened_fit;
    result.trend_nT_per_day = trend_fit.trend_nT_per_day;
    result.trend_stderr_nT_per_day = trend_fit.trend_stderr_nT_per_day;
  }

  // Quality figures, as for Eq. 2 but over the weighted cells.
  result.coherence = Eigen::Vector3d::Ones() - residual_power.cwiseQuotient(test_power);
  result.residual_rms_nT = inband_variance.cwiseSqrt();
  apply_quality_rules(result, fit.a, static_cast<long>(cells.size()), "section harmonics", settings_);
  return result;
}

}  // namespace magnetometer_insitu_calibration
