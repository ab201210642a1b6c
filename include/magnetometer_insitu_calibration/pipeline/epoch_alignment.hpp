// How two streams of magnetometer readings come onto common epochs before a window is estimated:
// one rule for records (prepare_pair) and live streams (LiveCalibrationStreams).
#pragma once

namespace magnetometer_insitu_calibration {

/// How two records or streams came onto common epochs (pre-processing steps 2-3).
enum class EpochAlignment {
  kPairedStamps,         ///< paired by stamp at their own rate, the estimation period
  kPairedThenDecimated,  ///< paired by stamp, then low-passed and decimated together
  /// Two rates (a 1 s record beside a 10 Hz one), or one rate with the stamps of one further off
  /// the other's than the pairing tolerance (a logger stamping at half seconds): each low-passed
  /// onto the estimation epochs by the same Gaussian FIR, then paired.
  kEachFiltered,
};
const char* epoch_alignment_name(EpochAlignment alignment);  ///< JSON: "paired_stamps", ...

/// The rule's outcome: how, and at what estimation period (s).
struct EpochPlan {
  EpochAlignment alignment = EpochAlignment::kPairedStamps;
  double period_s = 1.0;
};

/// Two sample periods within this ratio of each other are one rate.
constexpr double kSameRateRatio = 1.01;

/// The rule, for a reference and another stream (a test, a remote) of nominal periods
/// reference_period_s and other_period_s (s), an estimation period asked for of
/// output_period_s (s), and whether their stamps fall at different phases of one period:
///  * two rates, or stamps apart: kEachFiltered at max(output_period_s, the slower period);
///  * else, faster than 0.99 output_period_s: kPairedThenDecimated at output_period_s;
///  * else kPairedStamps at the streams' period.
/// The slower stream is filtered too, so the filter adds no relative response to n.
EpochPlan plan_epochs(double reference_period_s, double other_period_s, double output_period_s, bool stamps_apart);

}  // namespace magnetometer_insitu_calibration
