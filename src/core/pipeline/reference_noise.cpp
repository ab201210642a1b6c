// The reference's noise from a third instrument: see reference_noise.hpp.
#include "magnetometer_insitu_calibration/pipeline/reference_noise.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/estimation/frequency_bins.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <map>
#include <vector>

namespace magnetometer_insitu_calibration {

namespace {

/// Each bin of each of `bins` (PSDs of bins [low, high) Hz, their standard deviations or floors,
/// nT^2/Hz) divided by the filter's mean power gain over it: the PSD before the filter.
void undo_filter(const DecimationSettings* filter, const std::vector<double>& low, const std::vector<double>& high,
                 std::initializer_list<std::vector<Eigen::Vector3d>*> bins) {
  if (filter == nullptr) return;
  for (std::size_t b = 0; b < low.size(); ++b) {
    const double gain = mean_power_gain(*filter, low[b], high[b]);
    for (std::vector<Eigen::Vector3d>* values : bins) {
      if (b < values->size()) (*values)[b] /= gain;
    }
  }
}

/// min |a x - b| over x >= 0 in two unknowns (a has at least one row): the unconstrained
/// solution when both are >= 0, else the better of the two one-term fits (zero when neither is
/// positive). With one row the two one-term fits are both exact and the choice between them
/// would fall to rounding: the first term (white) only.
Eigen::Vector2d non_negative_fit(const Eigen::MatrixX2d& a, const Eigen::VectorXd& b) {
  Eigen::Vector2d x = Eigen::Vector2d::Zero();
  if (a.rows() == 1) {
    x(0) = std::max(0.0, b(0) / a(0, 0));
    return x;
  }
  x = a.colPivHouseholderQr().solve(b);
  if (x(0) >= 0.0 && x(1) >= 0.0) return x;
  double best = b.squaredNorm();
  x.setZero();
  for (int j = 0; j < 2; ++j) {
    const double v = a.col(j).dot(b) / a.col(j).squaredNorm();
    const double misfit = (a.col(j) * v - b).squaredNorm();
    if (v > 0.0 && misfit < best) {
      best = misfit;
      x.setZero();
      x(j) = v;
    }
  }
  return x;
}

}  // namespace

bool fit_white_and_pink(const std::vector<Eigen::Vector3d>& psd, const std::vector<double>& low,
                        const std::vector<double>& high, double dt, Eigen::Vector3d& white_nT,
                        Eigen::Vector3d& pink_nT_per_sqrt_hz) {
  return fit_white_and_pink(psd, {}, low, high, dt, white_nT, pink_nT_per_sqrt_hz, nullptr);
}

bool fit_white_and_pink(const std::vector<Eigen::Vector3d>& psd, const std::vector<Eigen::Vector3d>& psd_sd,
                        const std::vector<double>& low, const std::vector<double>& high, double dt,
                        Eigen::Vector3d& white_nT, Eigen::Vector3d& pink_nT_per_sqrt_hz, NoiseLevelCovariance* covariance,
                        const std::vector<Eigen::Vector3d>* scatter_floor) {
  white_nT.setZero();
  pink_nT_per_sqrt_hz.setZero();
  if (covariance != nullptr) covariance->fill(Eigen::Matrix2d::Zero());
  if (covariance != nullptr && psd_sd.size() != psd.size())
    throw InputError("fit_white_and_pink", "one standard deviation per bin is needed for the covariance");
  if (scatter_floor != nullptr && scatter_floor->size() != psd.size())
    throw InputError("fit_white_and_pink", "one scatter floor per bin is needed");
  bool all = true;
  for (int c = 0; c < 3; ++c) {
    // Every finite bin enters, negative ones too: a bin's estimate scatters about its true value,
    // of either sign where the noise is small against that scatter, and leaving out the negative
    // ones would bias the level up.
    std::vector<std::size_t> used;
    std::vector<Eigen::RowVector2d> design;  // [2 dt, mean(1/f) over the bin]: S = design . (w^2, p^2)
    double common_scale = 0.0;               // mean |S| of the axis's bins, nT^2/Hz
    for (std::size_t k = 0; k < psd.size(); ++k) {
      const double s = psd[k](c);
      if (!std::isfinite(s)) continue;
      used.push_back(k);
      design.emplace_back(2.0 * dt, std::log(high[k] / low[k]) / (high[k] - low[k]));
      common_scale += std::abs(s);
    }
    if (used.empty() || !(common_scale > 0.0)) {
      all = false;
      continue;
    }
    common_scale /= static_cast<double>(used.size());
    double mean_width = 0.0;  // Hz
    for (const std::size_t k : used) mean_width += (high[k] - low[k]) / static_cast<double>(used.size());
    // Least squares relative to each bin's model value: first with one scale for all bins (the
    // first fit's model is not known yet), then twice relative to the previous fit's model value.
    // Not relative to the bin's own value: a value near zero would take all the
    // weight, and the levels jumped when one ulp of the input moved it; weighting by the noisy
    // value itself also favours low bins and biases the level low. With a scatter floor (the
    // cross-spectral hat) each row is weighted by its harmonics too, sqrt(bin width) (the width
    // times the record's duration), relative to model + floor: the hat's estimate scatters by
    // (N + floor) / sqrt(harmonics), and equal weights let a log-spaced bottom bin of 16 harmonics
    // count as much as a top one of thousands. Without one (the pair's noise) every
    // bin counts equally relative to its model: the pair's top bins carry what a pair cannot
    // cancel, the test's response mismatch, and weighting them by their harmonics moved the
    // disturbed records' scale errors by +0.15 standard errors on average (docs/validation.md,
    // design choices).
    Eigen::Vector2d x = Eigen::Vector2d::Zero();
    const auto rows = static_cast<Eigen::Index>(used.size());
    Eigen::MatrixX2d a(rows, 2);
    Eigen::VectorXd b(rows), relative_sd(rows);
    for (int pass = 0; pass < 3; ++pass) {
      for (Eigen::Index i = 0; i < rows; ++i) {
        const std::size_t k = used[static_cast<std::size_t>(i)];
        const double model = design[static_cast<std::size_t>(i)].dot(x);
        const double floor = scatter_floor != nullptr && std::isfinite((*scatter_floor)[k](c)) ? (*scatter_floor)[k](c) : 0.0;
        // sqrt of the bin's harmonics relative to the mean bin's (bin widths in Hz)
        const double sqrt_harmonics = scatter_floor != nullptr ? std::sqrt((high[k] - low[k]) / mean_width) : 1.0;
        const double scale = ((pass == 0 || !(model > 0.0) ? common_scale : model) + floor) / sqrt_harmonics;
        a.row(i) = design[static_cast<std::size_t>(i)] / scale;
        b(i) = psd[k](c) / scale;
        if (covariance != nullptr) relative_sd(i) = psd_sd[k](c) / scale;
      }
      x = non_negative_fit(a, b);
    }
    white_nT(c) = std::sqrt(x(0));
    pink_nT_per_sqrt_hz(c) = std::sqrt(x(1));
    if (!(x(0) > 0.0) && !(x(1) > 0.0)) all = false;
    if (covariance == nullptr) continue;
    // The unconstrained linear fit's covariance, (A^T A)^-1 A^T diag(sd^2) A (A^T A)^-1, whether or
    // not a level came out at its bound of zero: a level fitted as zero is still uncertain by this.
    // With one bin only the level that was fitted gets its variance.
    const Eigen::Matrix2d ata = a.transpose() * a;
    if (rows >= 2 && std::abs(ata.determinant()) > 1e-12 * ata.squaredNorm()) {
      const Eigen::Matrix2d inverse = ata.inverse();
      const Eigen::MatrixX2d weighted = relative_sd.asDiagonal() * a;
      (*covariance)[static_cast<std::size_t>(c)] = inverse * (weighted.transpose() * weighted) * inverse;
    } else {
      for (int j = 0; j < 2; ++j) {
        if (x(j) > 0.0) (*covariance)[static_cast<std::size_t>(c)](j, j) = relative_sd.cwiseQuotient(a.col(j)).squaredNorm() / static_cast<double>(rows * rows);
      }
    }
  }
  return all;
}

bool fit_hat_instrument(const ThreeCorneredHatResult& hat, std::size_t instrument, double dt, Eigen::Vector3d& white_nT,
                        Eigen::Vector3d& pink_nT_per_sqrt_hz, NoiseLevelCovariance* covariance) {
  if (instrument > 2) throw InputError("fit_hat_instrument", "instrument must be 0, 1 or 2");
  const auto& floor = hat.psd_floor_nT2_per_hz[instrument];
  return fit_white_and_pink(hat.psd_nT2_per_hz[instrument], hat.psd_sd_nT2_per_hz[instrument], hat.bin_low_hz,
                            hat.bin_high_hz, dt, white_nT, pink_nT_per_sqrt_hz, covariance,
                            floor.empty() ? nullptr : &floor);
}

namespace {

/// Row of each grid epoch (time rounded to the period, s) where every one of `values` is finite.
std::map<long long, Eigen::Index> finite_epoch_rows(const std::vector<double>& time_s, double period_s,
                                                    const std::vector<const Readings*>& values) {
  std::map<long long, Eigen::Index> rows;
  for (std::size_t i = 0; i < time_s.size(); ++i) {
    const auto r = static_cast<Eigen::Index>(i);
    bool finite = true;
    for (const Readings* v : values) finite = finite && v->row(r).allFinite();
    if (finite) rows[std::llround(time_s[i] / period_s)] = r;
  }
  return rows;
}

/// "" unless the test and the third are one record (up to a linear map: a topic remapped twice, a
/// copied file): then the hat gives both a noise of zero to rounding, and all of it to the
/// reference. Only that case is refused. A quiet instrument beside noisy ones also gets
/// estimates near zero, of either sign, but at the scale of the others' noise over the bin's
/// harmonics (a 10 pT test beside 100 and 50 pT instruments: negative in about half its bins),
/// not of rounding; its estimate is then uncertain, the reference's is not.
std::string one_record_twice(const ThreeCorneredHatResult& hat, const std::string& third_name) {
  static const char* const kAxis = "xyz";
  for (int c = 0; c < 3; ++c) {
    double reference = 0.0, tests = 0.0;
    for (std::size_t k = 0; k < hat.psd_nT2_per_hz[0].size(); ++k) {
      reference = std::max(reference, std::abs(hat.psd_nT2_per_hz[0][k](c)));
      tests = std::max({tests, std::abs(hat.psd_nT2_per_hz[1][k](c)), std::abs(hat.psd_nT2_per_hz[2][k](c))});
    }
    if (tests <= 1e-9 * reference) {
      return std::string("the test and ") + third_name + " have no noise of their own on " + kAxis[c] +
             " (to rounding): one record twice, the independence the hat needs fails";
    }
  }
  return "";
}

/// Fewest harmonics in the hat's lowest bin: its PSD then has at least 13 degrees of freedom
/// (count - 3), a level scattering by about 14 %.
constexpr long kMinHarmonicsPerBin = 16;

/// The most log-spaced bins, up to `most`, whose lowest one over [low, high] holds
/// kMinHarmonicsPerBin harmonics j / duration; 1 when even one bin holds fewer.
int bins_for(double duration_s, double low_hz, double high_hz, int most) {
  for (int b = most; b > 1; --b) {
    const double top = low_hz * std::pow(high_hz / low_hz, 1.0 / b);
    const long first = static_cast<long>(std::ceil(low_hz * duration_s - 1e-9));
    const long last = static_cast<long>(std::ceil(top * duration_s - 1e-9)) - 1;
    if (last - first + 1 >= kMinHarmonicsPerBin) return b;
  }
  return 1;
}

/// The hat's bins: bins_for's log-spaced bins over the band, then kPairNoiseBins log-spaced
/// bins from the band's top to kPairNoiseTopOfNyquist of the Nyquist frequency (none when the
/// band reaches it). The cross-spectral hat cancels the field in every bin, so the bins above
/// the band need no gap below them (the pair's noise does); they hold most of the record's
/// harmonics and so fix the white level, where one day's in-band harmonics (about 850 at 1 s)
/// leave a quiet instrument's level undetermined beside a noisy one.
std::vector<double> hat_bin_edges(double duration_s, double sample_period_s, double band_low_hz, double band_high_hz,
                                  int bins) {
  std::vector<double> edges =
      log_spaced_bin_edges(band_low_hz, band_high_hz, bins_for(duration_s, band_low_hz, band_high_hz, bins));
  const double top = kPairNoiseTopOfNyquist * 0.5 / sample_period_s;
  if (top > band_high_hz) {
    const std::vector<double> above = log_spaced_bin_edges(band_high_hz, top, kPairNoiseBins);
    edges.insert(edges.end(), above.begin() + 1, above.end());  // band_high_hz once
  }
  return edges;
}

}  // namespace

double mean_power_gain(const DecimationSettings& filter, double low_hz, double high_hz) {
  constexpr int kPoints = 64;  // midpoints: the gain is smooth over a bin
  double sum = 0.0;
  for (int k = 0; k < kPoints; ++k) {
    const double f = low_hz + (high_hz - low_hz) * (k + 0.5) / kPoints;
    const double g = gaussian_gain(filter.effective_sigma_s(), f);
    sum += g * g;
  }
  return sum / kPoints;
}

IdentifiedNoise identify_reference_noise(const PairedRecord& with_test, const VectorRecord& third,
                                         double sample_period_s, double band_low_hz, double band_high_hz, int bins,
                                         const std::string& third_name, const DecimationSettings* filter) {
  IdentifiedNoise out;
  out.sample_period_s = sample_period_s;
  const std::map<long long, Eigen::Index> test_rows =
      finite_epoch_rows(with_test.time_s, sample_period_s, {&with_test.reference_nT, &with_test.test_nT});
  const std::map<long long, Eigen::Index> third_rows = finite_epoch_rows(third.time_s, sample_period_s, {&third.values_nT});
  std::vector<std::pair<long long, std::pair<Eigen::Index, Eigen::Index>>> common;  // epoch, (test row, third row)
  for (const auto& [epoch, row] : test_rows) {
    const auto it = third_rows.find(epoch);
    if (it != third_rows.end()) common.push_back({epoch, {row, it->second}});
  }
  // The hat needs one regular record: the longest run of consecutive shared epochs.
  std::size_t best_first = 0, best_count = 0;
  for (std::size_t i = 0, first = 0; i <= common.size(); ++i) {
    const bool breaks = i == common.size() || (i > first && common[i].first != common[i - 1].first + 1);
    if (!breaks) continue;
    if (i - first > best_count) {
      best_first = first;
      best_count = i - first;
    }
    first = i;
  }
  if (best_count < 64) {
    throw InputError(third_name, "the reference, the test and " + third_name + " share " + std::to_string(best_count) +
                                     " consecutive epochs on the estimation grid (at least 64 needed)");
  }
  out.samples = best_count;
  const auto n = static_cast<Eigen::Index>(best_count);
  Readings r(n, 3), t(n, 3), c(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& rows = common[best_first + static_cast<std::size_t>(i)].second;
    r.row(i) = with_test.reference_nT.row(rows.first);
    t.row(i) = with_test.test_nT.row(rows.first);
    c.row(i) = third.values_nT.row(rows.second);
  }
  ThreeCorneredHatSettings hs;
  hs.bin_edges_hz = hat_bin_edges(static_cast<double>(n) * sample_period_s, sample_period_s, band_low_hz,
                                  band_high_hz, bins);
  out.hat = three_cornered_hat(r, t, c, out.sample_period_s, hs);
  for (std::size_t k = 0; k < 3; ++k) {
    undo_filter(filter, out.hat.bin_low_hz, out.hat.bin_high_hz,
                {&out.hat.psd_nT2_per_hz[k], &out.hat.psd_sd_nT2_per_hz[k], &out.hat.psd_floor_nT2_per_hz[k],
                 &out.hat.pair_psd_nT2_per_hz[k]});
  }
  char text[320];
  const std::string shared = one_record_twice(out.hat, third_name);
  if (!shared.empty()) {
    std::snprintf(text, sizeof text, "reference noise not identified by the three-cornered hat with %s (%zu epochs): %s",
                  third_name.c_str(), out.samples, shared.c_str());
    out.text = text;
    return out;
  }
  fit_hat_instrument(out.hat, 0, out.sample_period_s, out.white_nT, out.pink_nT_per_sqrt_hz, &out.level_covariance);
  out.identified = (out.white_nT.array() > 0.0).any() || (out.pink_nT_per_sqrt_hz.array() > 0.0).any();
  if (out.identified) {
    std::snprintf(text, sizeof text,
                  "reference noise from the three-cornered hat with %s (%zu epochs, %zu bins): white %.3g/%.3g/%.3g pT "
                  "rms, 1/f %.3g/%.3g/%.3g pT/sqrt(Hz) at 1 Hz (x/y/z)",
                  third_name.c_str(), out.samples, out.hat.bin_low_hz.size(), 1e3 * out.white_nT(0), 1e3 * out.white_nT(1),
                  1e3 * out.white_nT(2), 1e3 * out.pink_nT_per_sqrt_hz(0), 1e3 * out.pink_nT_per_sqrt_hz(1),
                  1e3 * out.pink_nT_per_sqrt_hz(2));
  } else {
    std::snprintf(text, sizeof text,
                  "reference noise not identified by the three-cornered hat with %s (%zu epochs): its bins do not "
                  "support a positive level on any axis (noise shared between instruments?)",
                  third_name.c_str(), out.samples);
  }
  out.text = text;
  return out;
}

ReferenceNoiseModel IdentifiedNoise::model(NoiseSource source, const std::string& provider) const {
  ReferenceNoiseModel out;
  if (!identified) return out;
  out.source = source;
  out.spectrum.white_nT = white_nT;
  out.spectrum.pink_nT_per_sqrt_hz = pink_nT_per_sqrt_hz;
  out.level_covariance = level_covariance;
  out.provider = provider;
  return out;
}

IdentifiedNoise identify_reference_noise_from_pair(const Eigen::Ref<const Readings>& reference_nT,
                                                   const Eigen::Ref<const Readings>& test_nT, double sample_period_s,
                                                   const WindowEstimate& estimate, const ResponseModel& model,
                                                   double band_high_hz, const DecimationSettings* filter) {
  IdentifiedNoise out;
  out.sample_period_s = sample_period_s;
  const double nyquist = 0.5 / sample_period_s;  // Hz
  const double low = std::max(band_high_hz, kPairNoiseLowOfNyquist * nyquist), top = kPairNoiseTopOfNyquist * nyquist;
  char text[320];
  const auto refuse = [&](const std::string& why) {
    out.text = "reference noise not identified from the pair: " + why;
    return out;
  };
  if (model.applied) return refuse("the test's filter is modelled above the band (" + model.text + ")");
  if (!estimate.n.allFinite() || estimate.quality != Quality::kOk) return refuse("the window's first estimate failed");
  if (!(low < top)) return refuse("the band reaches the top of the bins above it");
  // The longest run of epochs with all six values finite.
  std::size_t best_first = 0, best_count = 0;
  if (reference_nT.rows() != test_nT.rows()) throw InputError("two_instrument_noise", "records of unequal length");
  const auto rows = static_cast<std::size_t>(reference_nT.rows());
  for (std::size_t i = 0, first = 0; i <= rows; ++i) {
    const bool bad = i == rows || !reference_nT.row(static_cast<Eigen::Index>(i)).allFinite() ||
                     !test_nT.row(static_cast<Eigen::Index>(i)).allFinite();
    if (!bad) continue;
    if (i - first > best_count) {
      best_first = first;
      best_count = i - first;
    }
    first = i + 1;
  }
  out.samples = best_count;
  const auto first = static_cast<Eigen::Index>(best_first), count = static_cast<Eigen::Index>(best_count);
  RelativeTransfer transfer;
  if (model.fitted) transfer.delay_s = model.delay_s;
  PhaseTransferFit roll_off;
  try {
    // A test whose gain falls across the bins would pass for reference noise: its corner from
    // the phase, which the reference's noise does not touch.
    const PairSpectra spectra =
        pair_spectra(reference_nT.middleRows(first, count), test_nT.middleRows(first, count), sample_period_s);
    roll_off = fit_transfer_from_phase(spectra, estimate.n, transfer.delay_s, low, top, kPairNoiseBins);
    if (roll_off.any_corner()) transfer = roll_off.transfer;
    out.pair = two_instrument_noise(spectra, estimate.n, transfer, low, top, kPairNoiseBins);
  } catch (const InputError& e) {
    return refuse(e.problem());
  }
  undo_filter(filter, out.pair.bin_low_hz, out.pair.bin_high_hz,
              {&out.pair.reference_psd, &out.pair.reference_psd_sd, &out.pair.coherent_psd});
  fit_white_and_pink(out.pair.reference_psd, out.pair.reference_psd_sd, out.pair.bin_low_hz, out.pair.bin_high_hz,
                     sample_period_s, out.white_nT, out.pink_nT_per_sqrt_hz, &out.level_covariance);
  out.identified = (out.white_nT.array() > 0.0).any() || (out.pink_nT_per_sqrt_hz.array() > 0.0).any();
  if (!out.identified) return refuse("the bins above the band do not support a positive level on any axis");
  std::snprintf(text, sizeof text,
                "reference noise from the pair above the band (%.3g-%.3g Hz, %zu epochs): white %.3g/%.3g/%.3g pT rms, "
                "1/f %.3g/%.3g/%.3g pT/sqrt(Hz) at 1 Hz (x/y/z)",
                low, top, out.samples, 1e3 * out.white_nT(0), 1e3 * out.white_nT(1), 1e3 * out.white_nT(2),
                1e3 * out.pink_nT_per_sqrt_hz(0), 1e3 * out.pink_nT_per_sqrt_hz(1), 1e3 * out.pink_nT_per_sqrt_hz(2));
  out.text = text;
  if (!roll_off.text.empty()) out.text += "; " + roll_off.text;
  return out;
}

}  // namespace magnetometer_insitu_calibration

