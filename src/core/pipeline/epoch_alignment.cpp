// The rule that brings two streams onto common epochs: see epoch_alignment.hpp.
#include "magnetometer_insitu_calibration/pipeline/epoch_alignment.hpp"

#include <algorithm>

namespace magnetometer_insitu_calibration {

const char* epoch_alignment_name(EpochAlignment alignment) {
  switch (alignment) {
    case EpochAlignment::kPairedStamps: return "paired_stamps";
    case EpochAlignment::kPairedThenDecimated: return "paired_then_decimated";
    case EpochAlignment::kEachFiltered: return "each_filtered";
  }
  return "unknown";
}

EpochPlan plan_epochs(double reference_period_s, double other_period_s, double output_period_s, bool stamps_apart) {
  const double slower = std::max(reference_period_s, other_period_s);
  const bool two_rates = slower > kSameRateRatio * std::min(reference_period_s, other_period_s);
  if (two_rates || stamps_apart) return {EpochAlignment::kEachFiltered, std::max(output_period_s, slower)};
  if (slower < 0.99 * output_period_s) return {EpochAlignment::kPairedThenDecimated, output_period_s};
  return {EpochAlignment::kPairedStamps, slower};
}

}  // namespace magnetometer_insitu_calibration
