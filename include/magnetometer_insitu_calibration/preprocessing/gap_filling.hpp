// Regular time grid and gap filling for a paired (reference, test) record.
#pragma once

#include "magnetometer_insitu_calibration/preprocessing/time_alignment.hpp"

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace magnetometer_insitu_calibration {

struct GapSettings {
  /// Gaps whose missing span (number of missing epochs * sample period) exceeds this are still
  /// filled but listed in GapReport::long_gaps, s; the window stage flags a window that has one
  /// (window_calibration.hpp). One hour: on simulated quiet days, gaps bridged by straight lines
  /// in both records (one of 10, 30 or 60 min a day, or three of 20 min) left the default's
  /// errors and coverage where they were without gaps, and so did an hour cut from the real WIC
  /// day (docs/accuracy.md, "Gaps"); what limits gaps is the share of the window they fill.
  double max_fill_s = 3600.0;
};

struct GapReport {
  std::size_t filled_samples = 0;  ///< output epochs whose values were interpolated
  /// Gaps longer than max_fill_s: [first, last] indices on the output grid (inclusive).
  std::vector<std::pair<std::size_t, std::size_t>> long_gaps;
  std::vector<std::uint8_t> filled;  ///< per output epoch: 1 where a value was interpolated
  std::size_t inserted_epochs = 0;   ///< grid epochs that had no paired sample at all
  std::size_t masked_samples = 0;    ///< epochs present but with a NaN in one of the six values
  std::size_t trimmed_leading = 0;   ///< NaN epochs cut from the start of the grid
  std::size_t trimmed_trailing = 0;  ///< NaN epochs cut from the end of the grid
};

/// Rule:
///  1. Grid: epochs t0 + k * sample_period_s, k = 0, 1, ...; the phase t0 is the median phase
///     of the stamps (so one early or late first stamp does not shift the grid). Each sample is
///     snapped to its nearest epoch and must lie within sample_period_s / 4 of it; epochs
///     without a sample are inserted as NaN. paired.time_s becomes the exact grid epochs.
///  2. Mask: an epoch where any of the six values (reference x, y, z, test x, y, z) is NaN is
///     NaN in all six, so the relation T = R n (and any linear trend) cannot be broken by
///     filling one instrument and not the other.
///  3. Trim: NaN epochs before the first and after the last complete epoch are removed
///     (counted in trimmed_leading / trimmed_trailing).
///  4. Fill: every remaining run of NaN epochs is replaced, in both records and every column,
///     by the straight line between the complete epochs on either side. Interpolating both
///     records at the same epochs with the same weights keeps T = R n exactly and reproduces a
///     signal linear in time exactly. Runs whose span exceeds max_fill_s are filled too but
///     listed in long_gaps, so callers can flag the analysis windows that overlap them.
/// Counters (unpaired_*, duplicates) of `paired` are left as they are.
///
/// Throws InputError("--reference/--test", ...) for a stamp off the grid, two stamps on one
/// epoch, stamps not increasing, or no complete epoch; InputError("sample_period_s" /
/// "max_fill_s", ...) for impossible settings.
GapReport regularize_and_fill(PairedRecord& paired, double sample_period_s,
                              const GapSettings& settings);

/// Steps 1-3 alone: the regular grid, incomplete epochs NaN in all six values, trimmed. Fills
/// inserted_epochs, masked_samples and the trimmed counts of the report.
GapReport regularize(PairedRecord& paired, double sample_period_s);

/// Step 4 alone, on a record that regularize() has put on its grid: fills filled,
/// filled_samples and long_gaps. Throws InputError when the record starts or ends with an
/// incomplete epoch.
GapReport fill_gaps(PairedRecord& paired, double sample_period_s, const GapSettings& settings);

}  // namespace magnetometer_insitu_calibration
