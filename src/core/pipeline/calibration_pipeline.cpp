// Offline calibration of a record pair: pre-processing, windows, the per-window stage.
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"
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

/// How a reference and another record come onto common epochs: their median periods (s), where
/// the other's stamps fall against the reference's at one rate (s; 0 for two rates) and the rule.
struct RecordsPlan {
  double reference_period_s = 0.0, other_period_s = 0.0, stamp_offset_s = 0.0;
  EpochPlan plan;
};

RecordsPlan plan_records(const VectorRecord& reference, const VectorRecord& other, const PreprocessSettings& settings) {
  RecordsPlan out;
  out.reference_period_s = median_sample_period(reference);
  out.other_period_s = median_sample_period(other);
  const double native_period = std::max(out.reference_period_s, out.other_period_s);
  const bool one_rate = native_period <= kSameRateRatio * std::min(out.reference_period_s, out.other_period_s);
  if (one_rate) out.stamp_offset_s = stamp_offset_s(reference, other, native_period);
  out.plan = plan_epochs(out.reference_period_s, out.other_period_s, settings.output_period_s,
                         std::abs(out.stamp_offset_s) > settings.pairing_tolerance_s);
  return out;
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
  const RecordsPlan records = plan_records(reference, test, settings);
  rep.stamp_offset_s = records.stamp_offset_s;
  const EpochPlan plan = records.plan;
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

/// A copy of `record` with the spikes removed as prepare_pair removes them (despike() on each
/// record at its own rate), or as it is without despiking.
VectorRecord despiked(const VectorRecord& record, const PreprocessSettings& settings) {
  VectorRecord out = record;
  if (settings.despike) despike(out.values_nT, settings.despike_settings);
  return out;
}

/// Refuses a side record that cannot come onto the epochs, naming `option`: fewer than two
/// samples, no finite sample, a stamp not finite or going backwards (a repeated stamp is dropped,
/// as for the pair).
void check_side_record(const VectorRecord& side, const char* option) {
  if (side.size() < 2) throw InputError(option, "fewer than two samples");
  if (!side.values_nT.array().isFinite().rowwise().all().any()) {
    throw InputError(option, "no sample has three finite components (all missing or NaN)");
  }
  for (std::size_t i = 0; i < side.size(); ++i) {
    if (!std::isfinite(side.time_s[i])) throw InputError(option, "time stamp of sample " + std::to_string(i) + " is not finite");
    if (i > 0 && side.time_s[i] < side.time_s[i - 1]) {
      throw InputError(option, "time goes backwards at sample " + std::to_string(i));
    }
  }
}

/// A side record on the estimation epochs (side_stream.hpp): the whole record and the despiked
/// reference through the SideStream the live streams use, at the pair's estimation period.
std::shared_ptr<const SideStream> side_stream_of(const VectorRecord& reference, const VectorRecord& despiked_reference,
                                                 const VectorRecord& side, const PreparedPair& prepared,
                                                 const PreprocessSettings& settings, const char* option) {
  check_side_record(side, option);
  SideStreamSettings s;
  const RecordsPlan records = plan_records(reference, side, settings);
  s.reference_period_s = records.reference_period_s;
  s.side_period_s = records.other_period_s;
  s.stamps_apart = std::abs(records.stamp_offset_s) > settings.pairing_tolerance_s;
  s.decimation.output_period_s = settings.output_period_s;
  s.pairing_tolerance_s = settings.pairing_tolerance_s;
  s.despike = settings.despike;
  s.despike_settings = settings.despike_settings;
  s.time_jump_threshold_s = std::numeric_limits<double>::infinity();  // a record: its gaps are NaN epochs
  const double period_s = s.plan().period_s;
  if (std::abs(period_s - prepared.sample_period_s) > 1e-9 * prepared.sample_period_s) {
    std::ostringstream text;
    text << "comes onto the epochs every " << period_s << " s, the test's pair every " << prepared.sample_period_s
         << " s: the windows need one estimation period";
    throw InputError(option, text.str());
  }
  std::shared_ptr<SideStream> out;
  try {
    out = std::make_shared<SideStream>(s);
  } catch (const InputError& e) {  // name the side record, not the stream's fields
    throw InputError(option, e.problem());
  }
  for (std::size_t i = 0; i < despiked_reference.size(); ++i) {
    out->push_reference(despiked_reference.time_s[i], despiked_reference.values_nT.row(static_cast<Eigen::Index>(i)).transpose());
  }
  for (std::size_t i = 0; i < side.size(); ++i) out->push(side.time_s[i], side.values_nT.row(static_cast<Eigen::Index>(i)).transpose());
  out->finish();
  const VectorRecord on_epochs = out->on_epochs(-std::numeric_limits<double>::infinity(),
                                                std::numeric_limits<double>::infinity());
  if (!on_epochs.values_nT.array().isFinite().rowwise().all().any()) {
    throw InputError(option, "has no sample on the reference's epochs (the records do not overlap in time, or their "
                             "stamps lie further apart than the pairing tolerance): reference " +
                                 reference.source + " spans " + time_for_message(reference.time_s.front()) + " to " +
                                 time_for_message(reference.time_s.back()) + ", " + option + " " + side.source +
                                 " spans " + time_for_message(side.time_s.front()) + " to " +
                                 time_for_message(side.time_s.back()));
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
    w.third = std::make_shared<const VectorRecord>(sides->third->on_epochs(from_s, to_s));
    w.third_name = sides->third_name;
  }
  if (sides->remote) {
    w.remote = std::make_shared<const VectorRecord>(sides->remote->on_epochs(from_s, to_s));
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
  if (sides.scalar != nullptr) out.scalar = std::make_shared<ScalarRecord>(*sides.scalar);
  if (sides.third == nullptr && sides.remote == nullptr) return out;
  const VectorRecord despiked_reference = despiked(reference, settings.preprocess);
  if (sides.third != nullptr) {
    out.third = side_stream_of(reference, despiked_reference, *sides.third, prepared, settings.preprocess, "--third");
    // The hat compares the three records' spectra above the band, where the Gaussian FIR's gain
    // falls: a third filtered where the pair is not (or the reverse) would show the filter as noise.
    if (out.third->filter().has_value() != prepared.decimation.has_value()) {
      throw InputError("--third", std::string("comes onto the epochs ") +
                                      (out.third->filter() ? "through the Gaussian FIR" : "at its stamps") + ", the pair " +
                                      (prepared.decimation ? "through the Gaussian FIR" : "paired by stamp") +
                                      ": the three-cornered hat needs the three records filtered alike (records of one "
                                      "rate and phase, or --output-period longer than their period)");
    }
  }
  if (sides.remote != nullptr) {
    out.remote = side_stream_of(reference, despiked_reference, *sides.remote, prepared, settings.preprocess, "--remote");
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
