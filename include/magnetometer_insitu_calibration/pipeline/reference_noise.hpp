// The reference's noise identified from the instruments themselves, for the errors-in-variables
// correction (errors_in_variables.hpp) when no maker's figure is given: with a third co-located
// instrument, the three-cornered hat (estimation/three_cornered_hat.hpp) gives each instrument's
// noise PSD from the pairwise Eq. 2 residuals; without one, the part of the reference's PSD above
// the band that is not coherent with the test (two_instrument_noise.hpp). The reference's PSD is
// fitted by white + 1/f noise per axis and given to the correction as a ReferenceNoiseModel
// (IdentifiedNoise::model). The per-window stage (window_calibration.hpp) chooses between them.
//
// What it assumes (three_cornered_hat.hpp): the three instruments' noises are independent. A
// disturbance seen by the reference only counts as its noise (and is then corrected for, as an
// error in the regressor should be); noise shared by two instruments makes the third's estimate
// too large and theirs too small, possibly negative: every bin enters the fit, and when the fit
// leaves both levels of every axis at zero the noise is reported as not identified (no
// correction).
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"
#include "magnetometer_insitu_calibration/estimation/response_model.hpp"
#include "magnetometer_insitu_calibration/estimation/three_cornered_hat.hpp"
#include "magnetometer_insitu_calibration/estimation/two_instrument_noise.hpp"
#include "magnetometer_insitu_calibration/preprocessing/gaussian_decimation.hpp"
#include "magnetometer_insitu_calibration/preprocessing/time_alignment.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <string>

namespace magnetometer_insitu_calibration {

struct IdentifiedNoise {
  bool identified = false;  ///< a non-zero white or 1/f level on at least one axis
  /// The reference's noise per axis of its frame: white, nT rms per sample at the estimation
  /// period; 1/f, nT/sqrt(Hz) at 1 Hz (the units of RobustSettings::reference_white_nT / _pink_).
  Eigen::Vector3d white_nT = Eigen::Vector3d::Zero();
  Eigen::Vector3d pink_nT_per_sqrt_hz = Eigen::Vector3d::Zero();
  /// Covariance of (white^2, pink^2) per axis (fd_wlse.hpp), from the per-bin standard
  /// deviations of the pair's or the hat's estimate.
  NoiseLevelCovariance level_covariance{Eigen::Matrix2d::Zero(), Eigen::Matrix2d::Zero(), Eigen::Matrix2d::Zero()};
  ThreeCorneredHatResult hat;   ///< every instrument's PSD per bin, and the pairwise residual PSDs
  TwoInstrumentNoise pair;      ///< from the pair alone: the reference's PSD per bin above the band
  std::size_t samples = 0;      ///< epochs used: all three records share them (hat); the pair's finite run
  double sample_period_s = 0.0; ///< of that grid, s
  std::string text;             ///< one line: levels, or why not identified

  /// The noise as the errors-in-variables correction takes it (source kNone when not
  /// identified), `provider` naming the instrument it was identified with.
  ReferenceNoiseModel model(NoiseSource source, const std::string& provider) const;
};

/// Fits S(f) = 2 w^2 dt + p^2 / f per axis to a PSD given per bin (nT^2/Hz, bins [low, high) Hz;
/// the 1/f term is averaged over each bin as ln(high / low) / (high - low)) by least squares
/// relative to each bin's model value, w^2 >= 0 and p^2 >= 0: a first fit with one scale for
/// all bins (the mean |S|), then two passes relative to the previous fit's model value. Every
/// finite bin enters, negative ones too (an estimate scatters about its true value; leaving out
/// the negative ones biases the level up), and the levels are continuous in the bins: not
/// weighting by each bin's own value, where a value near zero would take all the weight.
/// With one bin, a white level only. Returns false for an axis whose two levels come out zero
/// (no finite bin, or bins that do not support a positive level).
bool fit_white_and_pink(const std::vector<Eigen::Vector3d>& psd_nT2_per_hz, const std::vector<double>& bin_low_hz,
                        const std::vector<double>& bin_high_hz, double dt, Eigen::Vector3d& white_nT,
                        Eigen::Vector3d& pink_nT_per_sqrt_hz);

/// The same with each bin's standard deviation (nT^2/Hz), and the covariance of (w^2, p^2) per
/// axis: that of the unconstrained last pass, (A^T A)^-1 A^T diag(sd^2) A (A^T A)^-1 in the
/// relative rows, also when a level came out at its bound of zero. Throws
/// InputError("fit_white_and_pink", ...) when psd_sd does not hold one value per bin, or
/// scatter_floor (when given) not one per bin. scatter_floor (nT^2/Hz per bin, the hat's
/// ThreeCorneredHatResult::psd_floor_nT2_per_hz): a bin's scatter is then taken as (model +
/// floor) / sqrt(harmonics), harmonics from the bin's width; without it every bin counts equally
/// relative to its model value (the pair's noise, whose top bins carry the test's response
/// mismatch: docs/validation.md, design choices).
bool fit_white_and_pink(const std::vector<Eigen::Vector3d>& psd_nT2_per_hz,
                        const std::vector<Eigen::Vector3d>& psd_sd_nT2_per_hz, const std::vector<double>& bin_low_hz,
                        const std::vector<double>& bin_high_hz, double dt, Eigen::Vector3d& white_nT,
                        Eigen::Vector3d& pink_nT_per_sqrt_hz, NoiseLevelCovariance* covariance,
                        const std::vector<Eigen::Vector3d>* scatter_floor_nT2_per_hz = nullptr);

/// fit_white_and_pink of one instrument of the hat (0, 1, 2 = a, b, c), its bins weighted by its
/// own scatter floor; covariance as above (may be null).
bool fit_hat_instrument(const ThreeCorneredHatResult& hat, std::size_t instrument, double dt, Eigen::Vector3d& white_nT,
                        Eigen::Vector3d& pink_nT_per_sqrt_hz, NoiseLevelCovariance* covariance = nullptr);

/// The reference's noise by the three-cornered hat (three_cornered_hat.hpp) from the pair and a
/// third instrument's samples on one estimation grid of period sample_period_s (time_s on the
/// grid; NaN or absent = missing): the epochs where the reference, the test and the third are
/// all finite, cut to the longest run of consecutive ones. `third_name` names
/// the third in errors and in the text ("--third", "test 'b'"). Throws InputError(third_name,
/// ...) when the three share fewer than 64 consecutive epochs; the hat's errors (a bin without
/// harmonics) name "three_cornered_hat".
///
/// Shared noise: the hat assumes the three noises independent. Noise shared by the test and the
/// third makes their estimates too small and the reference's too large; the hat cannot see it
/// from three records, except in the extreme: the test and the third one record (a topic
/// remapped twice), whose noises then come out zero to rounding. That case is reported as not
/// identified (no correction), and the text says so. A quiet test's own estimate scatters about
/// zero (of either sign) and is not refused: the reference's estimate is not affected.
///
/// `filter`: the Gaussian FIR the three records went through on their way to the grid (the
/// window's decimation), or null. Its power gain falls across the bins above the band (0.1 at
/// 0.25 Hz for 1 s epochs), which a white + 1/f fit would take for 1/f noise: each bin is divided
/// by the filter's mean power gain over it, so that the fit is of the noise before the filter,
/// which the band (gain 0.996 or more at 1 s) keeps.
IdentifiedNoise identify_reference_noise(const PairedRecord& with_test, const VectorRecord& third,
                                         double sample_period_s, double band_low_hz, double band_high_hz,
                                         int bins = 4, const std::string& third_name = "--third",
                                         const DecimationSettings* filter = nullptr);

/// The reference's noise from the pair alone, without a third instrument or a maker's figure
/// (two_instrument_noise.hpp): over [max(band_high_hz, 0.03 / sample_period_s), 0.25 /
/// sample_period_s) in kPairNoiseBins log-spaced bins, the part of the reference's PSD not coherent with the test through the
/// window's first estimate (estimate.n, and model's delay), fitted by fit_white_and_pink and so
/// extrapolated into the band. reference_nT, test_nT: N x 3 on one regular grid (NaN = missing);
/// uses the longest run of epochs where all six values are finite.
/// Not identified (the text says why, no correction follows) when:
///  - the response model applied a corner (a modelled filter above the band: the field's part of
///    the reference's PSD, many times its noise there, would carry the corner's error),
///  - the estimate is not finite, the band's top is at or above 0.25 / dt, or a bin holds fewer
///    than 8 harmonics (a run shorter than about an hour at 1 s),
///  - the bins support no positive level on any axis (fit_white_and_pink).
/// `filter`: the Gaussian FIR the pair went through (the window's decimation), or null: each bin
/// divided by its mean power gain, as for the hat.
IdentifiedNoise identify_reference_noise_from_pair(const Eigen::Ref<const Readings>& reference_nT,
                                                   const Eigen::Ref<const Readings>& test_nT, double sample_period_s,
                                                   const WindowEstimate& estimate, const ResponseModel& model,
                                                   double band_high_hz, const DecimationSettings* filter = nullptr);

/// The mean power gain exp(-4 pi^2 sigma^2 f^2) of the Gaussian FIR of `filter` over [low_hz,
/// high_hz): what a record low-passed by it keeps of a flat PSD in that bin.
double mean_power_gain(const DecimationSettings& filter, double low_hz, double high_hz);

/// The pair's noise is measured over kPairNoiseBins log-spaced bins from kPairNoiseLowOfNyquist
/// (0.03 Hz at 1 s, 3x the default band's top: there the field's part of the reference's PSD is
/// tens of times its noise on the simulated stations, not hundreds, so that the first estimate's
/// attenuation leaves a few per cent of it) to kPairNoiseTopOfNyquist (0.25 Hz at 1 s) of the
/// Nyquist frequency. The package's own Gaussian FIR keeps only 0.1 of the power at 0.25 Hz for
/// 1 s epochs: its gain is undone bin by bin (`filter`). An observatory's own anti-alias filter,
/// unknown here, is not.
constexpr int kPairNoiseBins = 6;
constexpr double kPairNoiseLowOfNyquist = 0.06;
constexpr double kPairNoiseTopOfNyquist = 0.5;

}  // namespace magnetometer_insitu_calibration
