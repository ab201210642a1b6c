// The per-window stage: see window_calibration.hpp.
#include "magnetometer_insitu_calibration/pipeline/window_calibration.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "magnetometer_insitu_calibration/estimation/temperature_terms.hpp"
#include "magnetometer_insitu_calibration/pipeline/temperature_channel.hpp"
#include "magnetometer_insitu_calibration/pipeline/tolerance_verdicts.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <sstream>

namespace magnetometer_insitu_calibration {

namespace {

constexpr double kSecondsPerDay = 86400.0;

/// Offset of the window (see CalibrationWindow::offset_end_nT for the model and the interval).
void estimate_offset(CalibrationWindow& w, const PairedRecord& paired) {
  const WindowEstimate& e = w.estimate;
  const auto rows = paired.reference_nT.rows();
  if (rows < 2 || !e.n.allFinite()) return;
  double t_centre = 0.0;
  for (double t : paired.time_s) t_centre += t;
  t_centre /= static_cast<double>(paired.time_s.size());
  const Eigen::Vector3d mean_r = paired.reference_nT.colwise().mean().transpose();
  const Eigen::Vector3d mean_t = paired.test_nT.colwise().mean().transpose();
  const Eigen::Vector3d trend_per_s = e.trend_nT_per_day / kSecondsPerDay;
  const Eigen::Vector3d d = mean_t - e.n.transpose() * mean_r;
  Eigen::Vector3d sum2 = Eigen::Vector3d::Zero();  // time-domain residual about the fitted model
  for (Eigen::Index i = 0; i < rows; ++i) {
    const Eigen::Vector3d residual = paired.test_nT.row(i).transpose() - e.n.transpose() * paired.reference_nT.row(i).transpose() -
                                     d - trend_per_s * (paired.time_s[static_cast<std::size_t>(i)] - t_centre);
    sum2 += residual.cwiseAbs2();
  }
  const double count = static_cast<double>(rows);
  const double dt = w.end_s - t_centre;
  w.offset_centre_nT = d;
  w.reference_mean_nT = mean_r;
  w.offset_end_nT = d + trend_per_s * dt;
  for (int l = 0; l < 3; ++l) {
    Eigen::Matrix3d column_covariance;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) column_covariance(a, b) = e.n_covariance(vec_index(a, l), vec_index(b, l));
    const double trend_se_per_s = e.trend_stderr_nT_per_day(l) / kSecondsPerDay;
    const double variance = mean_r.dot(column_covariance * mean_r) + sum2(l) / count / count +
                            dt * dt * trend_se_per_s * trend_se_per_s;
    w.offset_end_ci95_nT(l) = kNormalQuantile95 * std::sqrt(std::max(0.0, variance));
  }
}

/// The remote's samples (on the estimation epochs already, side_stream.hpp) as one row per epoch
/// of the filled window (each sample's row found from its stamp): runs of missing epochs inside
/// bridged by straight lines, at the edges held from the nearest sample. An instrument filled so
/// is still one (a function of the remote's record alone, independent of the local errors): what
/// it costs is strength, which the estimator measures. "" when usable, else why not: fewer than
/// kMinRemoteCover of the epochs have a sample (too short an overlap).
constexpr double kMinRemoteCover = 0.5;

std::string remote_rows(const VectorRecord& remote, const std::vector<double>& epochs, double period_s,
                        Readings& out) {
  const auto n = static_cast<Eigen::Index>(epochs.size());
  out = Readings::Constant(n, 3, std::numeric_limits<double>::quiet_NaN());
  if (n == 0) return "no epoch";
  const double start = epochs.front();
  std::vector<char> have(static_cast<std::size_t>(n), 0);
  std::size_t count = 0;
  for (std::size_t i = 0; i < remote.time_s.size(); ++i) {
    const long long k = std::llround((remote.time_s[i] - start) / period_s);
    if (k < 0 || k >= n || !remote.values_nT.row(static_cast<Eigen::Index>(i)).allFinite()) continue;
    out.row(static_cast<Eigen::Index>(k)) = remote.values_nT.row(static_cast<Eigen::Index>(i));
    count += have[static_cast<std::size_t>(k)] == 0;
    have[static_cast<std::size_t>(k)] = 1;
  }
  if (static_cast<double>(count) < kMinRemoteCover * static_cast<double>(n)) {
    std::ostringstream text;
    text << "it has samples at " << count << " of the window's " << n << " epochs (fewer than "
         << 100.0 * kMinRemoteCover << " %: too short an overlap)";
    return text.str();
  }
  Eigen::Index last = -1;  // the last epoch with a sample
  for (Eigen::Index i = 0; i <= n; ++i) {
    if (i < n && !have[static_cast<std::size_t>(i)]) continue;
    for (Eigen::Index k = last + 1; k < i; ++k) {
      if (last < 0) out.row(k) = out.row(i);                                // leading edge: hold
      else if (i >= n) out.row(k) = out.row(last);                          // trailing edge: hold
      else out.row(k) = out.row(last) + (out.row(i) - out.row(last)) * double(k - last) / double(i - last);
    }
    last = i;
  }
  return "";
}

/// Step 5 (window_calibration.hpp).
void apply_gap_rule(CalibrationWindow& w, const WindowCalibrationSettings& settings) {
  const double fraction = static_cast<double>(w.missing()) / static_cast<double>(w.expected_samples);
  if (!w.long_gap && !(fraction > settings.max_filled_fraction)) return;
  std::ostringstream text;
  text << w.missing() << " of " << w.expected_samples << " samples interpolated or missing";
  if (w.long_gap) text << ", a gap longer than " << settings.gaps.max_fill_s << " s (--max-fill, ~max_fill)";
  if (w.estimate.quality != Quality::kOk) text << "; also " << w.estimate.quality_text;
  w.estimate.quality = Quality::kGaps;
  w.estimate.quality_text = text.str();
}

}  // namespace

void WindowCalibrationSettings::validate() const {
  estimator.validate();
  ReferenceNoiseModel figure;
  figure.spectrum = reference_noise_figure;
  try {
    figure.validate();
  } catch (const InputError& e) {
    throw InputError("reference_noise_figure", e.problem());
  }
  if (response_model || relative_response) response.validate();
  if (response_model) model.validate();
  if (!(temperature.min_range_C >= 0.0) || !std::isfinite(temperature.min_range_C))
    throw InputError("temperature_min_range", "must be a finite temperature range >= 0 degC");
  if (!(temperature_max_gap_s > 0.0) || !std::isfinite(temperature_max_gap_s))
    throw InputError("temperature_max_gap", "must be a positive time in s");
  if (!(gaps.max_fill_s >= 0.0) || !std::isfinite(gaps.max_fill_s)) throw InputError("max_fill", "must be a time >= 0 s");
  if (!(max_filled_fraction >= 0.0 && max_filled_fraction <= 1.0))
    throw InputError("max_filled_fraction", "must be in [0, 1]");
  tolerances.validate();
}

Eigen::VectorXd temperature_on_grid(const TemperatureSamples& samples, const std::vector<double>& at, double max_gap_s) {
  const auto n = static_cast<Eigen::Index>(at.size());
  Eigen::VectorXd out = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::quiet_NaN());
  if (samples.time_s.empty() || n == 0) return out;
  out = interpolate_channel(samples.time_s, samples.value_C, at, max_gap_s);
  // The first and last finite samples hold over at most max_gap_s beyond them.
  std::size_t first = 0, last = samples.time_s.size();
  while (first < samples.time_s.size() && !std::isfinite(samples.value_C[first])) ++first;
  while (last > first && !std::isfinite(samples.value_C[last - 1])) --last;
  if (first >= last) return out;
  const double t_first = samples.time_s[first], t_last = samples.time_s[last - 1];
  for (Eigen::Index i = 0; i < n; ++i) {
    const double t = at[static_cast<std::size_t>(i)];
    if (t < t_first && t_first - t <= max_gap_s) out(i) = samples.value_C[first];
    if (t > t_last && t - t_last <= max_gap_s) out(i) = samples.value_C[last - 1];
  }
  return out;
}

WindowCalibrator::WindowCalibrator(const WindowCalibrationSettings& settings)
    : settings_((settings.validate(), settings)), estimator_(settings.estimator), scalar_estimator_(settings.estimator) {}

WindowCalibrator::~WindowCalibrator() = default;

/// Step 3 with the given inputs: the estimate, the response model, the temperature terms and
/// the relative response of the filled window. Returns the estimator's own parameters of the
/// window, before the response model and the temperature terms (the sub-windows' yardstick).
CalibrationParameters WindowCalibrator::estimate_pass(CalibrationWindow& w, const PairedRecord& paired,
                                     const Eigen::VectorXd& temperature_C, double period_s,
                                     const WindowInputs& inputs) {
  const Readings& reference = paired.reference_nT;
  Readings test = paired.test_nT;  // loses a modelled filter, then the temperature terms
  const WindowEstimateFunction estimate_again = [&](const Eigen::Ref<const Readings>& r,
                                                    const Eigen::Ref<const Readings>& t, double period) {
    return estimator_.estimate(r, t, period, inputs);
  };
  w.estimate = estimator_.estimate(reference, test, period_s, inputs);
  const CalibrationParameters estimator_parameters = w.estimate.parameters;
  // The bands' gains corrected for the reference noise n was corrected for.
  RelativeResponseSettings response = settings_.response;
  if (w.estimate.eiv == ErrorsInVariables::kApplied) response.reference_noise = inputs.reference_noise.spectrum;
  w.response_model = ResponseModel{};
  if (settings_.response_model) {
    w.response_model = with_response_model(estimate_again, reference, test, period_s, response, settings_.model,
                                           w.estimate, w.estimate.remote.used ? inputs.remote_nT : nullptr);
  }
  const Readings before_temperature = w.response_model.applied ? test : Readings();
  w.temperature = TemperatureFit{};
  if (temperature_C.size() > 0) {
    w.temperature = with_temperature_terms(estimate_again, settings_.estimator, settings_.temperature, reference, test,
                                           temperature_C, period_s, w.estimate);
    if (w.temperature_known && !w.temperature.fitted) {  // as fit_temperature states them when it gets that far
      w.temperature.reference_C = temperature_C.mean();
      w.temperature.range_C = temperature_C.maxCoeff() - temperature_C.minCoeff();
    }
  }
  w.relative_response.clear();
  if (settings_.relative_response) {
    // Of the test as recorded (a modelled filter shows), without the temperature terms.
    const Readings shown =
        w.response_model.applied ? Readings(paired.test_nT - (before_temperature - test)) : test;
    w.relative_response = relative_response(reference, shown, w.estimate.n, period_s, response,
                                            w.estimate.remote.used ? inputs.remote_nT : nullptr);
  }
  const double band_low = std::isfinite(w.estimate.band_low_hz) ? w.estimate.band_low_hz : 0.0;
  const double band_high = std::isfinite(w.estimate.band_high_hz) ? w.estimate.band_high_hz : 0.5 / period_s;
  w.response = summarise_response(w.relative_response, band_low, band_high);
  return estimator_parameters;
}

/// Step 2 before any estimate: the maker's figure, or the hat with the window's third
/// instrument; the window's reference_noise says what was identified or why not.
ReferenceNoiseModel WindowCalibrator::noise_before_estimate(CalibrationWindow& w, const WindowRecords& window,
                                                            const PairedRecord& filled) {
  ReferenceNoiseModel noise = ReferenceNoiseModel::maker_figure(settings_.reference_noise_figure);
  if (!settings_.corrects_reference_noise() || noise.has_noise()) return noise;
  if (!settings_.three_cornered_hat || !window.third) return noise;
  try {
    w.reference_noise = identify_reference_noise(filled, *window.third, window.period_s,
                                                 settings_.estimator.band_low_hz, settings_.estimator.band_high_hz, 4,
                                                 window.third_name, window.decimation ? &*window.decimation : nullptr);
  } catch (const std::exception& e) {
    w.reference_noise = IdentifiedNoise{};
    w.reference_noise.text =
        "reference noise not identified by the three-cornered hat with " + window.third_name + ": " + e.what();
  }
  if (!w.reference_noise.identified) return noise;
  return w.reference_noise.model(NoiseSource::kThreeCorneredHat, window.third_name);
}

CalibrationWindow WindowCalibrator::calibrate(WindowRecords window) {
  CalibrationWindow w;
  w.start_s = window.start_s;
  w.end_s = window.end_s();
  w.expected_samples = window.expected_samples;
  if (window.paired.size() == 0) throw InputError("window", "no sample in the window");
  // Step 1: the grid, the gaps filled in both records.
  const double period = window.period_s;
  const GapReport gaps = regularize_and_fill(window.paired, period, settings_.gaps);
  const auto epoch = [&](double t) { return std::llround((t - window.start_s) / period); };
  const long long first = std::max(0LL, epoch(window.paired.time_s.front()));
  const long long last =
      std::min<long long>(static_cast<long long>(window.expected_samples) - 1, epoch(window.paired.time_s.back()));
  w.leading_missing = static_cast<std::size_t>(first);
  w.trailing_missing =
      static_cast<std::size_t>(std::max(0LL, static_cast<long long>(window.expected_samples) - 1 - last));
  w.interpolated = gaps.filled_samples;
  const double edge_gap_s = static_cast<double>(std::max(w.leading_missing, w.trailing_missing)) * period;
  w.long_gap = !gaps.long_gaps.empty() || edge_gap_s > settings_.gaps.max_fill_s;
  // The sensor temperature on the grid.
  Eigen::VectorXd temperature_C;
  w.temperature_samples = window.temperature.time_s.size();
  if (window.temperature.recorded && !window.temperature.time_s.empty()) {
    temperature_C = temperature_on_grid(window.temperature, window.paired.time_s, settings_.temperature_max_gap_s);
    w.temperature_known = temperature_C.size() > 0 && temperature_C.allFinite();
  }
  const char* without_temperature = window.temperature.recorded
                                        ? "no temperature sample in the window: estimated without temperature terms"
                                        : "no sensor temperature: estimated without temperature terms";
  // Steps 2 and 3.
  WindowInputs inputs;
  inputs.reference_noise = noise_before_estimate(w, window, window.paired);
  Readings remote;
  if (window.remote) {
    const std::string refused = remote_rows(*window.remote, window.paired.time_s, period, remote);
    if (refused.empty()) {
      inputs.remote_nT = &remote;
      inputs.remote_name = window.remote_name;
    } else {
      w.remote_refused = "remote " + window.remote_name + " refused: " + refused;
      if (!window.remote_late.empty()) w.remote_refused += " (" + window.remote_late + ")";
    }
  } else if (!window.remote_late.empty()) {
    w.remote_refused = "remote " + window.remote_name + " not used: " + window.remote_late;
  }
  CalibrationParameters estimator_parameters = estimate_pass(w, window.paired, temperature_C, period, inputs);
  if (temperature_C.size() == 0) w.temperature.text = without_temperature;
  if (settings_.corrects_reference_noise() && settings_.pair_noise && !inputs.reference_noise.has_noise()) {
    // No figure and no hat: the reference's noise from the pair above the band, through the
    // first estimate and its response model; then the window again with it.
    const std::string hat_text = w.reference_noise.text;
    try {
      w.reference_noise = identify_reference_noise_from_pair(window.paired.reference_nT, window.paired.test_nT, period,
                                                             w.estimate, w.response_model,
                                                             settings_.estimator.band_high_hz,
                                                             window.decimation ? &*window.decimation : nullptr);
    } catch (const std::exception& e) {
      w.reference_noise = IdentifiedNoise{};
      w.reference_noise.text = std::string("reference noise not identified from the pair: ") + e.what();
    }
    if (!hat_text.empty()) w.reference_noise.text = hat_text + "; " + w.reference_noise.text;
    if (w.reference_noise.identified) {
      inputs.reference_noise = w.reference_noise.model(NoiseSource::kPairAboveBand, "");
      estimator_parameters = estimate_pass(w, window.paired, temperature_C, period, inputs);
      if (temperature_C.size() == 0) w.temperature.text = without_temperature;
    }
  }
  if (!w.remote_refused.empty()) {  // the estimate is the pair's; it says why
    w.estimate.remote.given = true;
    w.estimate.remote.text = w.remote_refused;
  } else if (!window.remote_late.empty()) {  // on the remote's samples up to where it reached
    w.estimate.remote.text += "; " + window.remote_late;
  }
  // Steps 4, 4b and 5.
  estimate_offset(w, window.paired);
  if (window.scalar) {
    w.scalar = check_scalar(*window.scalar, window.paired, period, w.estimate, scalar_estimator_, inputs,
                            settings_.gaps, settings_.field_direction, window.decimation);
  }
  apply_gap_rule(w, settings_);
  // Step 6.
  decide_tolerances(w, window.paired, period, inputs, estimator_parameters);
  return w;
}

/// Step 6: the verdicts; the sub-windows are estimated only when one is undecided. A flagged
/// window is not a calibration (the node does not accept it, export_corrected does not apply it):
/// it gets no verdicts, whose intervals would be those of an estimate its rules refused.
void WindowCalibrator::decide_tolerances(CalibrationWindow& w, const PairedRecord& filled, double period_s,
                                         const WindowInputs& inputs, const CalibrationParameters& estimator_parameters) {
  w.verdicts.clear();
  if (w.estimate.quality != Quality::kOk) {
    w.narrowing.text = "not measured: the window is flagged (" + w.estimate.quality_text + ")";
    return;
  }
  const double length_s = static_cast<double>(w.expected_samples) * period_s;
  w.verdicts = tolerance_verdicts(w.estimate.parameters, settings_.tolerances, length_s, w.narrowing);
  const bool undecided = std::any_of(w.verdicts.begin(), w.verdicts.end(),
                                     [](const ToleranceVerdict& v) { return v.verdict == Verdict::kUndecided; });
  if (!undecided) return;
  w.narrowing = measure_interval_narrowing(estimator_, filled, period_s, inputs, estimator_parameters);
  w.verdicts = tolerance_verdicts(w.estimate.parameters, settings_.tolerances, length_s, w.narrowing);
}

}  // namespace magnetometer_insitu_calibration
