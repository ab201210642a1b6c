// The offline calibration of a reference and a test record: pre-processing as the paper
// describes it, the window layout, and each window through the per-window stage
// (window_calibration.hpp) that calibration_node uses too.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"
#include "magnetometer_insitu_calibration/pipeline/epoch_alignment.hpp"
#include "magnetometer_insitu_calibration/pipeline/side_stream.hpp"
#include "magnetometer_insitu_calibration/pipeline/window_calibration.hpp"
#include "magnetometer_insitu_calibration/preprocessing/despike.hpp"
#include "magnetometer_insitu_calibration/preprocessing/gaussian_decimation.hpp"
#include "magnetometer_insitu_calibration/preprocessing/time_alignment.hpp"

#include <array>
#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// Order of the steps (each instrument in its own frame, nT):
///  1. spikes removed in each record at its own rate (despike(): they become NaN), as
///     calibration_node's StreamingDespiker removes them from each stream;
///  2. samples paired by stamp within pairing_tolerance_s (align_by_time(); reference stamps);
///  3. when the records are sampled faster than output_period_s (e.g. LEMI-025 at 10 Hz), both
///     are Gaussian-FIR low-passed and decimated to it, kernels centred on the same epochs;
///  4. put on the regular grid, a NaN in either instrument masking both (regularize()); the
///     gaps are filled window by window, by the per-window stage.
struct PreprocessSettings {
  double pairing_tolerance_s = 0.010;  ///< largest stamp difference of a pair, s
  bool despike = true;
  DespikeSettings despike_settings;
  double output_period_s = 1.0;        ///< estimation sample period, s
  /// The test's sensor temperature (temperature_channel.hpp): "auto", "none" or a channel name.
  std::string temperature_channel = "auto";

  void validate() const;
};

/// Window layout. intervals > 0: the paper's layout, K equal contiguous intervals and then the
/// whole record. window_s > 0: sliding windows of window_s every step_s (full windows only).
/// Neither: the whole record as one window.
struct WindowLayout {
  int intervals = 0;
  double window_s = 0.0;
  double step_s = 0.0;

  void validate() const;
};

struct CalibrationSettings {
  PreprocessSettings preprocess;
  WindowLayout windows;
  /// The per-window stage: estimator, reference noise, response model, temperature, gap rule.
  WindowCalibrationSettings window;

  void validate() const;
};

/// What pre-processing did, for the report and the diagnostics.
struct PreprocessReport {
  std::size_t reference_samples = 0, test_samples = 0;
  double reference_period_s = 0.0, test_period_s = 0.0;  ///< median steps of the inputs
  /// One rate: where the test's stamps fall in each period against the reference's (their
  /// circular mean phases' difference, in [-period/2, period/2)), s; 0 for two rates.
  double stamp_offset_s = 0.0;
  std::size_t spikes_reference = 0, spikes_test = 0;      ///< values set to NaN
  std::size_t paired = 0, unpaired_reference = 0, unpaired_test = 0, duplicates = 0;
  EpochAlignment alignment = EpochAlignment::kPairedStamps;
  /// The records were low-passed (by the Gaussian FIR) on their way to common epochs.
  bool decimated() const { return alignment != EpochAlignment::kPairedStamps; }
  std::size_t grid_samples = 0;     ///< epochs of the regular estimation grid
  std::size_t missing_samples = 0;  ///< of those, without a complete pair (the windows fill them)
  std::size_t long_gaps = 0;        ///< runs of missing epochs longer than the gap rule's max_fill_s
  std::string temperature_channel;  ///< the test's channel used as its temperature, "" if none
  /// The records' component names (VectorRecord::components): what n's rows and columns are.
  std::array<std::string, 3> reference_components, test_components;
};

/// The paired record on the regular estimation grid.
struct PreparedPair {
  PairedRecord paired;  ///< time_s on the grid; NaN = missing (in all six values)
  double sample_period_s = 1.0;
  /// The decimation the pair went through (when decimated): each window carries it, and a scalar
  /// magnetometer's F goes through the same (check_scalar).
  std::optional<DecimationSettings> decimation;
  TemperatureSamples test_temperature;  ///< the test's sensor temperature as recorded; recorded false: none
};

struct PairCalibration {
  PreprocessReport report;
  std::vector<CalibrationWindow> windows;
};

/// Steps 1-4. Throws InputError naming the record (source) when the records cannot be paired.
/// The report counts runs of missing epochs longer than max_fill_s as long gaps.
PreparedPair prepare_pair(const VectorRecord& reference, const VectorRecord& test,
                          const PreprocessSettings& settings, PreprocessReport* report = nullptr,
                          double max_fill_s = GapSettings{}.max_fill_s);

/// Label of the window that spans the whole record (the paper's layout ends with it; the only
/// window without a layout). Reports and `export_corrected --window` find it by this label.
inline constexpr const char* kWholeRecordLabel = "whole record";

/// [first, count) index ranges and labels of the layout over `samples` samples at `period_s`.
struct WindowSpan {
  std::string label;
  std::size_t first = 0, count = 0;
};
std::vector<WindowSpan> plan_windows(std::size_t samples, double period_s, const WindowLayout& layout);

/// Records measured beside the pair that go with every window, each optional (null: none).
struct SideRecords {
  const VectorRecord* third = nullptr;   ///< a third co-located instrument, any frame (three-cornered hat)
  const VectorRecord* remote = nullptr;  ///< a remote observatory, any frame and units (remote reference)
  const ScalarRecord* scalar = nullptr;  ///< an absolute scalar magnetometer (the reference's scale along the field)
};

/// The side records, each on the estimation epochs on its own (side_stream.hpp: despiked, and
/// through the pair's Gaussian FIR when the pair's rule filters it); null: none. Each window
/// takes the samples of its epochs (SideStream::on_epochs), as the live windows do.
struct PreparedSides {
  std::shared_ptr<const SideStream> third, remote;
  std::shared_ptr<const ScalarRecord> scalar;  ///< as recorded: each window takes its own span
  std::string third_name = "--third", remote_name = "--remote";  ///< name them in texts
};

/// The window [first, first + count) of a prepared pair as the per-window stage takes it: the
/// grid's epochs (NaN = missing), the test's temperature samples within temperature_margin_s
/// of it and the side records' samples of the same epochs.
WindowRecords window_records(const PreparedPair& prepared, std::size_t first, std::size_t count,
                             double temperature_margin_s, const PreparedSides* sides = nullptr);

/// Calibrates every window of a prepared pair with one WindowCalibrator, with the side records.
/// Throws InputError("intervals", ...) before any window when K intervals of the record are too
/// short for the band (EstimatorSettings::too_few_harmonics, the rule of sliding windows).
std::vector<CalibrationWindow> calibrate_prepared(const PreparedPair& prepared, const CalibrationSettings& settings,
                                                  const PreparedSides* sides = nullptr);

/// The side records on the estimation epochs, each through a SideStream with the (despiked)
/// reference; InputError("--third" / "--remote", ...) when one has no sample on the reference's
/// epochs, comes onto them at another estimation period than the pair, or (the third) is
/// filtered unlike the pair.
PreparedSides prepare_sides(const VectorRecord& reference, const PreparedPair& prepared, const SideRecords& sides,
                            const CalibrationSettings& settings);

/// Everything: prepare_pair, prepare_sides, calibrate_prepared.
PairCalibration calibrate_records(const VectorRecord& reference, const VectorRecord& test,
                                  const CalibrationSettings& settings, const SideRecords& sides = {});

/// The estimates whose agreement the reports assess (window_agreement.hpp): the K intervals of
/// the paper's layout, or sliding windows that do not overlap (step >= window), in order. Empty
/// for a single window or overlapping windows, whose estimates are not independent.
std::vector<WindowEstimate> disjoint_window_estimates(const std::vector<CalibrationWindow>& windows);

/// Median step of a record's stamps, s (throws InputError(record.source) with < 2 samples).
double median_sample_period(const VectorRecord& record);

}  // namespace magnetometer_insitu_calibration
