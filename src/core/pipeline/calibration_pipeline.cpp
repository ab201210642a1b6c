// Offline calibration of a record pair: pre-processing, windows, the per-window stage.
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/time_steps.hpp"
#include "magnetometer_insitu_calibration/pipeline/temperature_channel.hpp"
#include "magnetometer_insitu_calibration/preprocessing/gap_filling.hpp"
#include "magnetometer_insitu_calibration/preprocessing/gaussian_decimation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <sstream>

namespace magnetometer_insitu_calibration {

void PreprocessSettings::validate() const {
  if (!(pairing_tolerance_s >= 0.0) || !std::isfinite(pairing_tolerance_s))
    throw InputError("pairing_tolerance_s", "must be a finite time >= 0 s");
  if (!(output_period_s > 0.0) || !std::isfinite(output_period_s))
    throw InputError("output_period_s", "must be a positive time in s");
  if (despike) despike_settings.validate();
  if (temperature_channel.empty()) throw InputError("temperature_channel", "must be auto, none or a channel name");
}

void WindowLayout::validate() const {
  if (intervals < 0) {
    throw InputError("intervals", "must be >= 1 (leave out the intervals and the window for the whole record as one "
                                  "window)");
  }
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
  windows.validate();
  window.validate();
  // Sliding windows too short for the band would all be flagged: refused before any is estimated.
  const std::string too_few = windows.window_s > 0.0 ? window.estimator.too_few_harmonics(windows.window_s) : "";
  if (!too_few.empty()) {
    std::ostringstream text;
    text << "of " << windows.window_s << " s " << too_few;
    throw InputError("window", text.str());
  }
}

double median_sample_period(const VectorRecord& record) {
  if (record.size() < 2) throw InputError(record.source, "fewer than two samples");
  return median_time_step(record.time_s);
}

namespace {

/// The test's stamps' phase against the reference's at one rate, s in [-period/2, period/2]; 0
/// when either has no common phase (pairing by stamp decides then).
double stamp_offset_s(const VectorRecord& reference, const VectorRecord& test, double period_s) {
  const double d = phase_offset_s(stamp_phase_s(test.time_s, period_s), stamp_phase_s(reference.time_s, period_s), period_s);
  return std::isfinite(d) ? d : 0.0;
}

VectorRecord as_record(const std::vector<double>& time_s, const Readings& values, const VectorRecord& like) {
  VectorRecord r;
  r.time_s = time_s;
  r.values_nT = values;
  r.components = like.components;
  r.source = like.source;
  r.station = like.station;
  return r;
}

/// `r`'s stamps and values without the samples whose stamp repeats the one before (a bag's
/// driver restart), counted in `repeated` as align_by_time counts them: the decimator wants
/// increasing stamps.
VectorRecord without_repeated_stamps(const VectorRecord& r, std::size_t& repeated) {
  std::vector<double> time_s;
  std::vector<Eigen::Index> rows;
  for (std::size_t i = 0; i < r.size(); ++i) {
    if (i > 0 && r.time_s[i] == r.time_s[i - 1]) {
      ++repeated;
      continue;
    }
    time_s.push_back(r.time_s[i]);
    rows.push_back(static_cast<Eigen::Index>(i));
  }
  if (rows.size() == r.size()) return r;
  Readings values(static_cast<Eigen::Index>(rows.size()), 3);
  for (std::size_t k = 0; k < rows.size(); ++k) values.row(static_cast<Eigen::Index>(k)) = r.values_nT.row(rows[k]);
  return as_record(time_s, values, r);
}

/// Epochs of the grid without a complete pair, and their runs longer than max_fill_s.
void count_missing(const PreparedPair& prepared, double max_fill_s, PreprocessReport& report) {
  const PairedRecord& p = prepared.paired;
  std::size_t run = 0;
  const auto end_run = [&] {
    if (static_cast<double>(run) * prepared.sample_period_s > max_fill_s) ++report.long_gaps;
    run = 0;
  };
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto r = static_cast<Eigen::Index>(i);
    if (p.reference_nT.row(r).allFinite() && p.test_nT.row(r).allFinite()) {
      end_run();
      continue;
    }
    ++report.missing_samples;
    ++run;
  }
  end_run();
}

}  // namespace

PreparedPair prepare_pair(const VectorRecord& reference, const VectorRecord& test,
                          const PreprocessSettings& settings, PreprocessReport* report, double max_fill_s) {
  settings.validate();
  PreprocessReport local;
  PreprocessReport& rep = report != nullptr ? *report : local;
  rep = PreprocessReport{};
  rep.reference_samples = reference.size();
  rep.test_samples = test.size();
  rep.reference_period_s = median_sample_period(reference);
  rep.test_period_s = median_sample_period(test);
  rep.reference_components = reference.components;
  rep.test_components = test.components;
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
  PreparedPair out;
  const auto count_pairs = [&] {
    rep.paired = out.paired.size();
    rep.unpaired_reference = out.paired.unpaired_reference;
    rep.unpaired_test = out.paired.unpaired_test;
    rep.duplicates = out.paired.duplicates;
  };
  const double native_period = std::max(rep.reference_period_s, rep.test_period_s);
  const bool one_rate = native_period <= kSameRateRatio * std::min(rep.reference_period_s, rep.test_period_s);
  if (one_rate) rep.stamp_offset_s = stamp_offset_s(ref, tst, native_period);
  const EpochPlan plan = plan_epochs(rep.reference_period_s, rep.test_period_s, settings.output_period_s,
                                     std::abs(rep.stamp_offset_s) > settings.pairing_tolerance_s);
  rep.alignment = plan.alignment;
  if (plan.alignment == EpochAlignment::kEachFiltered) {
    // 2-3. Two rates (a 1 s observatory record beside a 10 Hz LEMI-025), or stamps that do not
    // pair (one logger stamping at half seconds): each record through the same Gaussian FIR onto
    // the same epochs, then paired. The slower one is filtered too, so the filter adds no
    // relative response to n (its gain, 0.998 at 0.01 Hz for 1 s, would read as a scale); the
    // faster one's noise above the output Nyquist frequency is not folded into the band as a
    // subsampling would; the kernel centred on each epoch puts a record of another phase on it.
    DecimationSettings dec;
    dec.output_period_s = plan.period_s;
    std::size_t repeated = 0;
    out.paired = align_by_time(decimate(without_repeated_stamps(ref, repeated), dec),
                               decimate(without_repeated_stamps(tst, repeated), dec), settings.pairing_tolerance_s);
    count_pairs();
    rep.duplicates += repeated;
    out.decimation = dec;
  } else {
    // 2. Pairs by stamp.
    out.paired = align_by_time(ref, tst, settings.pairing_tolerance_s);
    count_pairs();
    // 3. Gaussian FIR and decimation when sampled faster than the estimation period.
    if (plan.alignment == EpochAlignment::kPairedThenDecimated) {
      DecimationSettings dec;
      dec.output_period_s = plan.period_s;
      const VectorRecord r = decimate(as_record(out.paired.time_s, out.paired.reference_nT, reference), dec);
      const VectorRecord t = decimate(as_record(out.paired.time_s, out.paired.test_nT, test), dec);
      out.paired.time_s = r.time_s;  // both decimated on the same epochs
      out.paired.reference_nT = r.values_nT;
      out.paired.test_nT = t.values_nT;
      out.decimation = dec;
    }
  }
  // 4. Regular grid, common mask; the windows fill the gaps.
  out.sample_period_s = plan.period_s;
  regularize(out.paired, out.sample_period_s);
  rep.grid_samples = out.paired.size();
  count_missing(out, max_fill_s, rep);
  // The test's sensor temperature as recorded; each window puts it on its grid.
  if (const AuxiliaryChannel* channel = find_temperature_channel(test, settings.temperature_channel)) {
    out.test_temperature.recorded = true;
    out.test_temperature.time_s = test.time_s;
    out.test_temperature.value_C = channel->values;
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
      char text[160];
      std::snprintf(text, sizeof text, "of %g s is longer than the record (%g s)", layout.window_s,
                    static_cast<double>(samples) * period_s);
      throw InputError("window", text);
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

/// The rows of a prepared side record within [low_s, high_s).
PairedRecord slice(const PairedRecord& q, double low_s, double high_s) {
  const auto lo = std::lower_bound(q.time_s.begin(), q.time_s.end(), low_s);
  const auto hi = std::lower_bound(lo, q.time_s.end(), high_s);
  const auto a = static_cast<Eigen::Index>(lo - q.time_s.begin()), rows = static_cast<Eigen::Index>(hi - lo);
  PairedRecord out;
  out.time_s.assign(lo, hi);
  out.reference_nT = q.reference_nT.middleRows(a, rows);
  out.test_nT = q.test_nT.middleRows(a, rows);
  return out;
}

/// A side record paired with the reference like the test, on the same estimation period.
std::unique_ptr<PreparedPair> prepare_side(const VectorRecord& reference, const VectorRecord& side,
                                           const PreparedPair& prepared, const CalibrationSettings& settings,
                                           const char* option) {
  std::unique_ptr<PreparedPair> out;
  try {
    out = std::make_unique<PreparedPair>(
        prepare_pair(reference, side, settings.preprocess, nullptr, settings.window.gaps.max_fill_s));
  } catch (const InputError& e) {  // name the side record, not the pair's own options
    throw InputError(option, "paired with the reference: " + e.problem());
  }
  if (std::abs(out->sample_period_s - prepared.sample_period_s) > 1e-9 * prepared.sample_period_s) {
    throw InputError(option, "its pair with the reference has another estimation period than the test's");
  }
  return out;
}

}  // namespace

WindowRecords window_records(const PreparedPair& prepared, std::size_t first, std::size_t count,
                             double temperature_margin_s, const PreparedSides* sides) {
  const PairedRecord& p = prepared.paired;
  const double period = prepared.sample_period_s;
  WindowRecords w;
  w.decimation = prepared.decimation;
  w.start_s = p.time_s[first];
  w.period_s = period;
  w.expected_samples = count;
  w.paired.time_s.assign(p.time_s.begin() + static_cast<std::ptrdiff_t>(first),
                         p.time_s.begin() + static_cast<std::ptrdiff_t>(first + count));
  w.paired.reference_nT = p.reference_nT.middleRows(static_cast<Eigen::Index>(first), static_cast<Eigen::Index>(count));
  w.paired.test_nT = p.test_nT.middleRows(static_cast<Eigen::Index>(first), static_cast<Eigen::Index>(count));
  const double low = w.start_s - period - temperature_margin_s, high = w.end_s() + period + temperature_margin_s;
  const TemperatureSamples& t = prepared.test_temperature;
  w.temperature.recorded = t.recorded;
  const auto from = std::lower_bound(t.time_s.begin(), t.time_s.end(), low);
  const auto to = std::upper_bound(from, t.time_s.end(), high);
  w.temperature.time_s.assign(from, to);
  w.temperature.value_C.assign(t.value_C.begin() + (from - t.time_s.begin()), t.value_C.begin() + (to - t.time_s.begin()));
  if (sides == nullptr) return w;
  w.scalar = sides->scalar;
  const double from_s = w.start_s - 0.5 * period, to_s = w.end_s() + 0.5 * period;
  if (sides->third) {
    w.third = std::make_shared<PairedRecord>(slice(sides->third->paired, from_s, to_s));
    w.third_name = sides->third_name;
  }
  if (sides->remote) {
    const PairedRecord r = slice(sides->remote->paired, from_s, to_s);
    auto remote = std::make_shared<VectorRecord>();
    remote->time_s = r.time_s;
    remote->values_nT = r.test_nT;
    w.remote = std::move(remote);
    w.remote_name = sides->remote_name;
  }
  return w;
}

std::vector<CalibrationWindow> calibrate_prepared(const PreparedPair& prepared, const CalibrationSettings& settings,
                                                  const PreparedSides* sides) {
  settings.validate();
  // Known only once the records are paired: their estimation period.
  const std::string above_nyquist = settings.window.estimator.band_above_nyquist(prepared.sample_period_s);
  if (!above_nyquist.empty()) throw InputError("band_high_hz", above_nyquist);
  // K intervals: their length is known only now, from the paired record's (the same rule as --window).
  if (settings.windows.intervals > 0) {
    const std::size_t k = static_cast<std::size_t>(settings.windows.intervals);
    const double interval_s = static_cast<double>(prepared.paired.size() / k) * prepared.sample_period_s;
    const std::string too_few = settings.window.estimator.too_few_harmonics(interval_s);
    if (!too_few.empty()) {
      const double record_s = static_cast<double>(prepared.paired.size()) * prepared.sample_period_s;
      std::ostringstream text;
      text << k << " intervals of the " << record_s << " s record: an interval of " << interval_s << " s " << too_few
           << "; at most " << std::floor(record_s / settings.window.estimator.harmonics_window_s()) << " intervals";
      throw InputError("intervals", text.str());
    }
  }
  WindowCalibrator calibrator(settings.window);
  std::vector<CalibrationWindow> out;
  for (const WindowSpan& span : plan_windows(prepared.paired.size(), prepared.sample_period_s, settings.windows)) {
    CalibrationWindow w = calibrator.calibrate(window_records(prepared, span.first, span.count,
                                                              settings.window.temperature_max_gap_s, sides));
    w.label = span.label;
    w.first_index = span.first;
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
    if (parts[i]->first_index + parts[i]->expected_samples > parts[i + 1]->first_index) return out;
  }
  for (const CalibrationWindow* w : parts) out.push_back(w->estimate);
  return out;
}

PreparedSides prepare_sides(const VectorRecord& reference, const PreparedPair& prepared, const SideRecords& sides,
                            const CalibrationSettings& settings) {
  PreparedSides out;
  if (sides.third != nullptr) {
    out.third = prepare_side(reference, *sides.third, prepared, settings, "--third");
    // The hat compares the three records' spectra above the band, where the Gaussian FIR's gain
    // falls: a third filtered where the pair is not (or the reverse) would show the filter as noise.
    if (out.third->decimation.has_value() != prepared.decimation.has_value()) {
      throw InputError("--third", std::string("comes onto the epochs ") +
                                      (out.third->decimation ? "through the Gaussian FIR" : "paired by stamp") +
                                      ", the pair " + (prepared.decimation ? "through the Gaussian FIR" : "paired by stamp") +
                                      ": the three-cornered hat needs the three records filtered alike (records of one "
                                      "rate and phase, or --output-period longer than their period)");
    }
  }
  if (sides.scalar != nullptr) out.scalar = std::make_shared<ScalarRecord>(*sides.scalar);
  if (sides.remote != nullptr) {
    out.remote = prepare_side(reference, *sides.remote, prepared, settings, "--remote");
    if (!sides.remote->station.empty()) out.remote_name = sides.remote->station;
  }
  return out;
}

PairCalibration calibrate_records(const VectorRecord& reference, const VectorRecord& test,
                                  const CalibrationSettings& settings, const SideRecords& sides) {
  settings.validate();
  PairCalibration result;
  const double max_fill = settings.window.gaps.max_fill_s;
  const PreparedPair prepared = prepare_pair(reference, test, settings.preprocess, &result.report, max_fill);
  const PreparedSides prepared_sides = prepare_sides(reference, prepared, sides, settings);
  result.windows = calibrate_prepared(prepared, settings, &prepared_sides);
  return result;
}

}  // namespace magnetometer_insitu_calibration
