// Offline calibration of a record pair: pre-processing, windows, estimates.
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/pipeline/reference_noise.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/estimation/robust_estimator.hpp"
#include "magnetometer_insitu_calibration/estimation/temperature_terms.hpp"
#include "magnetometer_insitu_calibration/pipeline/temperature_channel.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace magnetometer_insitu_calibration {

void PreprocessSettings::validate() const {
  if (!(pairing_tolerance_s >= 0.0) || !std::isfinite(pairing_tolerance_s))
    throw InputError("pairing_tolerance_s", "must be a finite time >= 0 s");
  if (!(output_period_s > 0.0) || !std::isfinite(output_period_s))
    throw InputError("output_period_s", "must be a positive time in s");
  if (!(max_filled_fraction >= 0.0 && max_filled_fraction <= 1.0))
    throw InputError("max_filled_fraction", "must be in [0, 1]");
  if (!(gaps.max_fill_s >= 0.0)) throw InputError("max_fill_s", "must be >= 0 s");
  if (despike) despike_settings.validate();
  if (temperature_channel.empty()) throw InputError("temperature_channel", "must be auto, none or a channel name");
}

void WindowLayout::validate() const {
  if (intervals < 0) throw InputError("intervals", "must be >= 0");
  if (intervals > 0 && window_s > 0.0)
    throw InputError("intervals", "give either intervals or window/step, not both");
  if (window_s < 0.0 || !std::isfinite(window_s)) throw InputError("window", "must be a positive time in s");
  if (window_s > 0.0) {
    if (!(step_s > 0.0) || !std::isfinite(step_s)) throw InputError("step", "must be a positive time in s");
    if (step_s > window_s) throw InputError("step", "is longer than the window: samples would be skipped");
  } else if (step_s != 0.0) {
    throw InputError("step", "given without a window");
  }
}

void CalibrationSettings::validate() const {
  preprocess.validate();
  estimator.validate();
  windows.validate();
  if (relative_response || response_model) response.validate();
  if (response_model) model.validate();
  if (!(temperature.min_range_C >= 0.0) || !std::isfinite(temperature.min_range_C))
    throw InputError("temperature_min_range", "must be a finite temperature range >= 0 degC");
}

double median_sample_period(const VectorRecord& record) {
  if (record.size() < 2) throw InputError(record.source, "fewer than two samples");
  std::vector<double> steps(record.size() - 1);
  for (std::size_t i = 1; i < record.size(); ++i) steps[i - 1] = record.time_s[i] - record.time_s[i - 1];
  std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
  return steps[steps.size() / 2];
}

namespace {

VectorRecord as_record(const std::vector<double>& time_s, const Readings& values, const VectorRecord& like) {
  VectorRecord r;
  r.time_s = time_s;
  r.values_nT = values;
  r.components = like.components;
  r.source = like.source;
  r.station = like.station;
  return r;
}

}  // namespace

PreparedPair prepare_pair(const VectorRecord& reference, const VectorRecord& test,
                          const PreprocessSettings& settings, PreprocessReport* report) {
  settings.validate();
  PreprocessReport local;
  PreprocessReport& rep = report != nullptr ? *report : local;
  rep = PreprocessReport{};
  rep.reference_samples = reference.size();
  rep.test_samples = test.size();
  rep.reference_period_s = median_sample_period(reference);
  rep.test_period_s = median_sample_period(test);
  for (const VectorRecord* r : {&reference, &test}) {
    if (!r->values_nT.array().isFinite().rowwise().all().any()) {
      throw InputError(r->source, "no sample has three finite components (all missing or NaN)");
    }
  }

  // 1. Spikes, each instrument at its own rate.
  VectorRecord ref = reference, tst = test;
  if (settings.despike) {
    rep.spikes_reference = despike(ref.values_nT, settings.despike_settings);
    rep.spikes_test = despike(tst.values_nT, settings.despike_settings);
  }
  // 2. Pairs by stamp.
  PreparedPair out;
  out.paired = align_by_time(ref, tst, settings.pairing_tolerance_s);
  rep.paired = out.paired.size();
  rep.unpaired_reference = out.paired.unpaired_reference;
  rep.unpaired_test = out.paired.unpaired_test;
  rep.duplicates = out.paired.duplicates;

  // 3. Gaussian FIR and decimation when sampled faster than the estimation period.
  const double native_period = std::max(rep.reference_period_s, rep.test_period_s);
  if (native_period < 0.99 * settings.output_period_s) {
    DecimationSettings dec;
    dec.output_period_s = settings.output_period_s;
    const VectorRecord r = decimate(as_record(out.paired.time_s, out.paired.reference_nT, reference), dec);
    const VectorRecord t = decimate(as_record(out.paired.time_s, out.paired.test_nT, test), dec);
    out.paired.time_s = r.time_s;  // both decimated on the same epochs
    out.paired.reference_nT = r.values_nT;
    out.paired.test_nT = t.values_nT;
    rep.decimated = true;
  }
  // 4. Regular grid, common mask, gaps filled in both.
  out.sample_period_s = rep.decimated ? settings.output_period_s : native_period;
  out.gaps = regularize_and_fill(out.paired, out.sample_period_s, settings.gaps);
  rep.grid_samples = out.paired.size();
  rep.filled_samples = out.gaps.filled_samples;
  rep.long_gaps = out.gaps.long_gaps.size();
  // 5. The test's temperature on the grid (slow: linear interpolation of the raw channel).
  if (const AuxiliaryChannel* channel = find_temperature_channel(test, settings.temperature_channel)) {
    out.test_temperature_C = interpolate_channel(test.time_s, channel->values, out.paired.time_s,
                                                 std::max(settings.gaps.max_fill_s, 2.0 * rep.test_period_s));
    rep.temperature_channel = channel->name;
  }
  return out;
}

std::vector<WindowSpan> plan_windows(std::size_t samples, double period_s, const WindowLayout& layout) {
  layout.validate();
  std::vector<WindowSpan> spans;
  if (layout.intervals > 0) {
    const std::size_t k = static_cast<std::size_t>(layout.intervals);
    for (std::size_t i = 0; i < k; ++i) {
      const std::size_t first = samples * i / k, last = samples * (i + 1) / k;
      spans.push_back({"interval " + std::to_string(i + 1) + "/" + std::to_string(k), first, last - first});
    }
    spans.push_back({kWholeRecordLabel, 0, samples});
  } else if (layout.window_s > 0.0) {
    const auto window = static_cast<std::size_t>(std::llround(layout.window_s / period_s));
    const auto step = std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(layout.step_s / period_s)));
    if (window > samples) {
      throw InputError("window", "of " + std::to_string(layout.window_s) + " s is longer than the record (" +
                                     std::to_string(samples * period_s) + " s)");
    }
    for (std::size_t first = 0, i = 1; first + window <= samples; first += step, ++i) {
      spans.push_back({"window " + std::to_string(i), first, window});
    }
  } else {
    spans.push_back({kWholeRecordLabel, 0, samples});
  }
  return spans;
}

namespace {

/// One window's estimate, response model, temperature terms and relative response with
/// `estimator` (of settings.estimator, or of it with an identified reference noise).
void estimate_span(CalibrationWindow& w, const PreparedPair& prepared, const WindowSpan& span,
                   const CalibrationSettings& settings, WindowEstimator& estimator) {
  const auto& p = prepared.paired;
  const EstimatorSettings& estimator_settings = estimator.settings();
  const auto reference = p.reference_nT.middleRows(span.first, span.count);
  const Readings recorded = p.test_nT.middleRows(span.first, span.count);
  Readings test = recorded;  // loses a modelled filter, then the temperature terms
  const WindowEstimateFunction estimate_again = [&](const Eigen::Ref<const Readings>& r,
                                                    const Eigen::Ref<const Readings>& t, double period) {
    return estimator.estimate(r, t, period);
  };
  w.estimate = estimator.estimate(reference, test, prepared.sample_period_s);
  const RelativeResponseSettings response = with_identified_reference_noise(settings.response, estimator_settings);
  w.response_model = ResponseModel{};
  if (settings.response_model) {
    w.response_model = with_response_model(estimate_again, reference, test, prepared.sample_period_s, response,
                                           settings.model, w.estimate);
  }
  const Readings before_temperature = w.response_model.applied ? test : Readings();
  w.temperature = TemperatureFit{};
  if (prepared.test_temperature_C.size() > 0) {
    w.temperature = with_temperature_terms(estimate_again, estimator_settings, settings.temperature, reference, test,
                                           prepared.test_temperature_C.segment(span.first, span.count),
                                           prepared.sample_period_s, w.estimate);
  }
  w.relative_response.clear();
  if (settings.relative_response) {
    // Of the test as recorded (a modelled filter shows), without the temperature terms.
    const Readings shown = w.response_model.applied ? Readings(recorded - (before_temperature - test)) : test;
    w.relative_response = relative_response(reference, shown, w.estimate.n, prepared.sample_period_s, response);
  }
}

}  // namespace

std::vector<CalibrationWindow> calibrate_prepared(const PreparedPair& prepared, const CalibrationSettings& settings) {
  settings.validate();
  const auto& p = prepared.paired;
  WindowEstimator estimator(settings.estimator);  // plain Eq. 2 or robust, from settings.estimator.method
  std::vector<CalibrationWindow> out;
  for (const WindowSpan& span : plan_windows(p.size(), prepared.sample_period_s, settings.windows)) {
    CalibrationWindow w;
    w.label = span.label;
    w.first_index = span.first;
    w.start_s = p.time_s[span.first];
    w.end_s = p.time_s[span.first + span.count - 1];
    for (std::size_t i = span.first; i < span.first + span.count; ++i) w.filled_samples += prepared.gaps.filled[i];
    for (const auto& gap : prepared.gaps.long_gaps) {
      w.overlaps_long_gap |= gap.first < span.first + span.count && gap.second >= span.first;
    }
    estimate_span(w, prepared, span, settings, estimator);
    if (settings.pair_noise && settings.estimator.awaits_identified_noise()) {
      // No figure and no third instrument: the reference's noise from the pair above the band,
      // then the window again with it (reference_noise.hpp).
      const IdentifiedNoise noise = identify_reference_noise_from_pair(
          p.reference_nT.middleRows(span.first, span.count), p.test_nT.middleRows(span.first, span.count),
          prepared.sample_period_s, w.estimate, w.response_model, settings.estimator.band_high_hz);
      w.reference_noise = noise.text;
      if (noise.identified) {
        WindowEstimator identified(with_identified_noise(settings.estimator, noise, "from the pair above the band"));
        estimate_span(w, prepared, span, settings, identified);
      }
    }
    const double filled_fraction = static_cast<double>(w.filled_samples) / static_cast<double>(span.count);
    if (w.estimate.quality == Quality::kOk &&
        (w.overlaps_long_gap || filled_fraction > settings.preprocess.max_filled_fraction)) {
      std::ostringstream text;
      text << w.filled_samples << " of " << span.count << " samples interpolated";
      if (w.overlaps_long_gap) text << ", overlaps a gap longer than " << settings.preprocess.gaps.max_fill_s << " s";
      w.estimate.quality = Quality::kGaps;
      w.estimate.quality_text = text.str();
    }
    out.push_back(std::move(w));
  }
  return out;
}

std::vector<WindowEstimate> disjoint_window_estimates(const std::vector<CalibrationWindow>& windows) {
  std::vector<const CalibrationWindow*> parts;
  for (const CalibrationWindow& w : windows) {
    if (w.label != kWholeRecordLabel) parts.push_back(&w);
  }
  std::sort(parts.begin(), parts.end(), [](const CalibrationWindow* a, const CalibrationWindow* b) {
    return a->first_index < b->first_index;
  });
  std::vector<WindowEstimate> out;
  if (parts.size() < 2) return out;
  for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
    if (parts[i]->first_index + parts[i]->estimate.samples > parts[i + 1]->first_index) return out;
  }
  for (const CalibrationWindow* w : parts) out.push_back(w->estimate);
  return out;
}

PairCalibration calibrate_records(const VectorRecord& reference, const VectorRecord& test,
                                  const CalibrationSettings& settings) {
  settings.validate();
  PairCalibration result;
  const PreparedPair prepared = prepare_pair(reference, test, settings.preprocess, &result.report);
  result.windows = calibrate_prepared(prepared, settings);
  return result;
}

}  // namespace magnetometer_insitu_calibration
