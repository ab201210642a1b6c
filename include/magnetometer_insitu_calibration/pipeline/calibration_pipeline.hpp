// The offline calibration of a reference and a test record: pre-processing as the paper
// describes it, the window layout, and one FD-WLSE estimate per window.
#pragma once

#include "magnetometer_insitu_calibration/preprocessing/despike.hpp"
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/estimation/relative_response.hpp"
#include "magnetometer_insitu_calibration/estimation/response_model.hpp"
#include "magnetometer_insitu_calibration/estimation/temperature_regression.hpp"
#include "magnetometer_insitu_calibration/preprocessing/gap_filling.hpp"
#include "magnetometer_insitu_calibration/preprocessing/gaussian_decimation.hpp"
#include "magnetometer_insitu_calibration/preprocessing/time_alignment.hpp"
#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <cstddef>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// Order of the steps (each instrument in its own frame, nT):
///  1. spikes removed in each record at its own rate (despike(): they become NaN);
///  2. samples paired by stamp within pairing_tolerance_s (align_by_time(); reference stamps);
///  3. when the records are sampled faster than output_period_s (e.g. LEMI-025 at 10 Hz), both
///     are Gaussian-FIR low-passed and decimated to it, kernels centred on the same epochs;
///  4. put on the regular grid, a NaN in either instrument masks both, and gaps interpolated
///     linearly in both at the same epochs (regularize_and_fill(): keeps T = R n exactly);
///  5. windows that hold more than max_filled_fraction interpolated samples, or overlap a gap
///     longer than gaps.max_fill_s, are estimated but flagged Quality::kGaps.
struct PreprocessSettings {
  double pairing_tolerance_s = 0.010;  ///< largest stamp difference of a pair, s
  bool despike = true;
  DespikeSettings despike_settings;
  GapSettings gaps;
  double output_period_s = 1.0;        ///< estimation sample period, s
  double max_filled_fraction = 0.05;   ///< of a window's samples, [0, 1]
  /// The test's sensor temperature (temperature_channel.hpp): "auto", "none" or a channel name.
  /// Interpolated onto the estimation grid (NaN across gaps longer than gaps.max_fill_s).
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
  EstimatorSettings estimator;
  WindowLayout windows;
  bool relative_response = true;  ///< estimate each window's relative frequency response
  RelativeResponseSettings response;
  /// Fit a delay + first-order low-pass per component to the response and, where a corner is
  /// significant, estimate n again on the test record with that filter removed (response_model.hpp).
  /// On by default since issue 14: where no corner is significant the estimate is unchanged.
  bool response_model = true;
  ResponseModelSettings model;
  /// Temperature terms when the test record has a temperature (temperature_regression.hpp); the
  /// band, gamma and trend follow each window's estimate, min_range_C is used as given.
  TemperatureBand temperature;
  /// With the robust method, EIV "given" and no reference noise given (no maker's figure, no
  /// third instrument): identify the reference's noise from the pair itself above the band and
  /// estimate each window again with it (identify_reference_noise_from_pair, reference_noise.hpp;
  /// issue 13). Off: no EIV correction then, as before session 9.
  bool pair_noise = true;

  void validate() const;
};

/// What pre-processing did, for the report and the diagnostics.
struct PreprocessReport {
  std::size_t reference_samples = 0, test_samples = 0;
  double reference_period_s = 0.0, test_period_s = 0.0;  ///< median steps of the inputs
  std::size_t spikes_reference = 0, spikes_test = 0;      ///< values set to NaN
  std::size_t paired = 0, unpaired_reference = 0, unpaired_test = 0, duplicates = 0;
  bool decimated = false;
  std::size_t grid_samples = 0;       ///< samples on the regular estimation grid
  std::size_t filled_samples = 0;     ///< of those, interpolated
  std::size_t long_gaps = 0;
  std::string temperature_channel;    ///< the test's channel used as its temperature, "" if none
};

/// The paired record on the regular estimation grid.
struct PreparedPair {
  PairedRecord paired;  ///< time_s on the grid; no NaN
  GapReport gaps;
  double sample_period_s = 1.0;
  Eigen::VectorXd test_temperature_C;  ///< on the grid, deg C; empty without a temperature channel
};

struct CalibrationWindow {
  std::string label;            ///< "interval 2/4", "whole record", "window 7"
  double start_s = 0.0;         ///< first sample, UNIX s
  double end_s = 0.0;           ///< last sample, UNIX s
  std::size_t first_index = 0;  ///< on the estimation grid
  std::size_t filled_samples = 0;
  bool overlaps_long_gap = false;
  WindowEstimate estimate;
  /// Gain and phase of T against R n per test component (relative_response.hpp), lowest band
  /// first; empty when not asked for or when no band has enough harmonics.
  std::vector<ResponseBand> relative_response;
  ResponseModel response_model;  ///< fitted when CalibrationSettings::response_model
  /// Temperature terms (fitted only when the test has a temperature that varies in the window);
  /// when fitted, estimate.n is at temperature.reference_C and its covariance includes the
  /// coefficients' uncertainty.
  TemperatureFit temperature;
  /// One line on the reference noise identified from the pair (CalibrationSettings::pair_noise),
  /// or why none was; empty when that step does not apply. estimate.eiv says what was applied.
  std::string reference_noise;
};

struct PairCalibration {
  PreprocessReport report;
  std::vector<CalibrationWindow> windows;
};

/// Steps 1-4. Throws InputError naming the record (source) when the records cannot be paired.
PreparedPair prepare_pair(const VectorRecord& reference, const VectorRecord& test,
                          const PreprocessSettings& settings, PreprocessReport* report = nullptr);

/// Label of the window that spans the whole record (the paper's layout ends with it; the only
/// window without a layout). Reports and `export_corrected --window` find it by this label.
inline constexpr const char* kWholeRecordLabel = "whole record";

/// [first, count) index ranges and labels of the layout over `samples` samples at `period_s`.
struct WindowSpan {
  std::string label;
  std::size_t first = 0, count = 0;
};
std::vector<WindowSpan> plan_windows(std::size_t samples, double period_s, const WindowLayout& layout);

/// Estimates every window of a prepared pair (step 5 included).
std::vector<CalibrationWindow> calibrate_prepared(const PreparedPair& prepared,
                                                  const CalibrationSettings& settings);

/// Everything: prepare_pair + calibrate_prepared.
PairCalibration calibrate_records(const VectorRecord& reference, const VectorRecord& test,
                                  const CalibrationSettings& settings);

/// The estimates whose agreement the reports assess (window_agreement.hpp): the K intervals of
/// the paper's layout, or sliding windows that do not overlap (step >= window), in order. Empty
/// for a single window or overlapping windows, whose estimates are not independent.
std::vector<WindowEstimate> disjoint_window_estimates(const std::vector<CalibrationWindow>& windows);

/// Median step of a record's stamps, s (throws InputError(record.source) with < 2 samples).
double median_sample_period(const VectorRecord& record);

}  // namespace magnetometer_insitu_calibration
