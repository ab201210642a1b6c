// The live streams of calibration: see live_streams.hpp.
#include "magnetometer_insitu_calibration/pipeline/live_streams.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

namespace magnetometer_insitu_calibration {

namespace {

void add_counters(PairingCounters& total, const PairingCounters& more) {
  total.paired += more.paired;
  total.unpaired_reference += more.unpaired_reference;
  total.unpaired_test += more.unpaired_test;
  total.late += more.late;
  total.duplicates += more.duplicates;
  total.invalid += more.invalid;
}

/// The filter at a plan's estimation period.
DecimationSettings filter_of(const LiveStreamSettings& settings, const EpochPlan& plan) {
  DecimationSettings d = settings.decimation;
  d.output_period_s = plan.period_s;
  return d;
}

/// The two decimators of a plan: after the pairer, both at the reference's period (they see the
/// paired stamps; the caller restarts them on a jump), or before it, each at its own stream's
/// period and restarting itself on a jump of its stamps. None when paired by stamp.
void make_decimators(const LiveStreamSettings& settings, double other_period_s, const EpochPlan& plan,
                     std::unique_ptr<StreamingDecimator>& reference, std::unique_ptr<StreamingDecimator>& other) {
  const DecimationSettings d = filter_of(settings, plan);
  if (plan.alignment == EpochAlignment::kPairedThenDecimated) {
    reference = std::make_unique<StreamingDecimator>(settings.input_period_s, d);
    other = std::make_unique<StreamingDecimator>(settings.input_period_s, d);
  } else if (plan.alignment == EpochAlignment::kEachFiltered) {
    reference = std::make_unique<StreamingDecimator>(settings.input_period_s, d, settings.time_jump_threshold_s);
    other = std::make_unique<StreamingDecimator>(other_period_s, d, settings.time_jump_threshold_s);
  }
}

/// One sample of a stream on its way to its pairer (`to`): as it is, or, when each stream is
/// filtered before pairing (kEachFiltered), through the stream's own decimator, each epoch it
/// completes; the decimator's restarts (a jump of the stream's stamps) counted.
template <typename To>
void to_pairer(EpochAlignment alignment, StreamingDecimator* filter, double time_s, const Eigen::Vector3d& value_nT,
               std::size_t& restarts, To to) {
  if (alignment != EpochAlignment::kEachFiltered) {
    to(time_s, value_nT);
    return;
  }
  const std::size_t before = filter->restarts();
  for (const auto& [epoch, filtered] : filter->push(time_s, value_nT)) to(epoch, filtered);
  restarts += filter->restarts() - before;
}

void require_period(const char* field, double period_s, bool zero_allowed) {
  if (!std::isfinite(period_s) || period_s < 0.0 || (!zero_allowed && period_s == 0.0)) {
    throw InputError(field, zero_allowed ? "must be a finite time >= 0 s (0: the reference's)" : "must be a positive time in s");
  }
}

/// The filter of a plan must span the period of the streams it takes.
void require_kernel_covers(const LiveStreamSettings& settings, const EpochPlan& plan, double other_period_s,
                           const char* field) {
  if (plan.alignment == EpochAlignment::kPairedStamps) return;
  const double slowest = plan.alignment == EpochAlignment::kEachFiltered
                             ? std::max(settings.input_period_s, other_period_s)
                             : settings.input_period_s;
  const double half_width = filter_of(settings, plan).half_width_s();
  if (half_width < slowest) {
    char text[200];
    std::snprintf(text, sizeof text, "of %g s: the filter's kernel (half-width %g s) is shorter than it", slowest,
                  half_width);
    throw InputError(field, text);
  }
}

}  // namespace

EpochPlan LiveStreamSettings::test_plan(double period_s) const {
  return plan_epochs(input_period_s, period_s > 0.0 ? period_s : test_period_s(), decimation.output_period_s,
                     stamps_apart);
}

std::optional<DecimationSettings> LiveStreamSettings::window_decimation(double period_s) const {
  const EpochPlan plan = test_plan(period_s);
  if (plan.alignment == EpochAlignment::kPairedStamps) return std::nullopt;
  return filter_of(*this, plan);
}

void LiveStreamSettings::validate(bool remote) const {
  require_period("input_period_s", input_period_s, false);
  require_period("test_input_period_s", test_input_period_s, true);
  require_period("remote_input_period_s", remote_input_period_s, true);
  if (!(remote_max_wait_s >= 0.0) || std::isnan(remote_max_wait_s)) {
    throw InputError("remote_max_wait_s", "must be a time >= 0 s");
  }
  decimation.validate();
  const EpochPlan test = test_plan();
  require_kernel_covers(*this, test, test_period_s(), "test_input_period_s");
  if (!remote) return;
  const EpochPlan far = remote_side().plan();
  require_kernel_covers(*this, far, remote_period_s(), "remote_input_period_s");
  if (std::abs(far.period_s - test.period_s) > 1e-9 * test.period_s) {
    char text[240];
    std::snprintf(text, sizeof text,
                  "of %g s puts the remote onto the epochs every %g s, the tests' pairs every %g s: the windows "
                  "need one estimation period",
                  remote_period_s(), far.period_s, test.period_s);
    throw InputError("remote_input_period_s", text);
  }
}

void LiveStreamSettings::validate_test_period(double period_s) const {
  require_period("input_period_s", period_s, false);
  const EpochPlan plan = test_plan(period_s);
  require_kernel_covers(*this, plan, period_s, "input_period_s");
  if (std::abs(plan.period_s - estimation_period_s()) > 1e-9 * estimation_period_s()) {
    char text[240];
    std::snprintf(text, sizeof text,
                  "of %g s puts the test's pairs with the reference every %g s, the others' every %g s: the windows "
                  "need one estimation period",
                  period_s, plan.period_s, estimation_period_s());
    throw InputError("input_period_s", text);
  }
}

void LiveStreamSettings::validate_test(const std::vector<LiveTestInput>& tests, std::size_t i, bool coincident) const {
  const double period = tests.at(i).input_period_s;
  if (period > 0.0) validate_test_period(period);
  if (coincident && i > 0 && window_decimation(period).has_value() != window_decimation(tests[0].input_period_s).has_value()) {
    throw InputError("input_period_s", "puts this test's windows through the Gaussian FIR where tests[0]'s are not, or "
                                       "the reverse: the three-cornered hat needs the tests filtered alike (give them "
                                       "one period, or no hat)");
  }
}

LiveTestStream::LiveTestStream(const LiveTestInput& input, const LiveStreamSettings& settings)
    : name(input.name),
      temperature(input.temperature),
      input_period_s(input.input_period_s > 0.0 ? input.input_period_s : settings.test_period_s()),
      despiker(settings.despike_settings),
      alignment(settings.test_plan(input_period_s).alignment),
      decimation(settings.window_decimation(input_period_s)),
      pairer(settings.pairing_tolerance_s, settings.pairing_max_wait_s),
      windows(settings.window_s, settings.step_s, settings.estimation_period_s()),
      thermometer(settings.window_s + 2.0 * settings.temperature_margin_s) {
  make_decimators(settings, input_period_s, settings.test_plan(input_period_s), reference_decimator, test_decimator);
}

SideStreamSettings LiveStreamSettings::remote_side() const {
  SideStreamSettings s;
  s.reference_period_s = input_period_s;
  s.side_period_s = remote_period_s();
  s.stamps_apart = stamps_apart;
  s.decimation = decimation;
  s.pairing_tolerance_s = pairing_tolerance_s;
  s.despike = despike;
  s.despike_settings = despike_settings;
  s.time_jump_threshold_s = time_jump_threshold_s;
  return s;
}

bool LiveScalarStream::push(double time_s, double value_nT) {
  ++received;
  if (!std::isfinite(time_s) || (!samples.empty() && !(time_s > samples.back().first))) {
    ++refused;
    return false;
  }
  samples.emplace_back(time_s, value_nT);
  return true;
}

std::shared_ptr<ScalarRecord> LiveScalarStream::copy(double low_s, double high_s) const {
  auto out = std::make_shared<ScalarRecord>();
  for (const auto& [time, value] : samples) {
    if (time < low_s || time > high_s) continue;
    out->time_s.push_back(time);
    out->value_nT.push_back(value);
  }
  out->source = name;
  return out;
}

void LiveScalarStream::drop_before(double time_s) {
  while (!samples.empty() && samples.front().first < time_s) samples.pop_front();
}

PairingCounters LiveTestStream::counters() const {
  PairingCounters total = counters_before_reset;
  add_counters(total, pairer.counters());
  return total;
}

LiveCalibrationStreams::LiveCalibrationStreams(const LiveStreamSettings& settings, const std::vector<LiveTestInput>& tests,
                                               bool coincident)
    : settings_(settings), reference_despiker_(settings.despike_settings) {
  settings_.validate(false);
  const bool hat = coincident && tests.size() >= 2;
  for (std::size_t i = 0; i < tests.size(); ++i) {
    settings_.validate_test(tests, i, hat);
    tests_.push_back(std::make_unique<LiveTestStream>(tests[i], settings));
  }
  if (hat) coincident_ = std::make_unique<CoincidentWindows>(tests_.size());
}

std::vector<LiveCalibrationStreams::Completed> LiveCalibrationStreams::push_reference(double time_s,
                                                                                     const Eigen::Vector3d& value_nT) {
  std::vector<Completed> out;
  StreamingDespiker::Sample s{time_s, value_nT};
  if (settings_.despike && !reference_despiker_.push(time_s, value_nT, s)) return out;
  if (remote_) {  // first: the reference's epochs of a window are in before the window completes
    remote_->push_reference(s.time_s, s.value_nT);
    drop_remote_epochs();
  }
  newest_pair_s_ = std::max(newest_pair_s_, s.time_s);
  for (std::size_t i = 0; i < tests_.size(); ++i) {
    LiveTestStream& t = *tests_[i];
    to_pairer(t.alignment, t.reference_decimator.get(), s.time_s, s.value_nT, t.decimator_restarts,
              [&t](double time, const Eigen::Vector3d& v) { t.pairer.push_reference(time, v); });
    drain(i, out);
  }
  release_waiting(out);
  return out;
}

void LiveCalibrationStreams::add_remote(const std::string& name) {
  settings_.validate(true);
  remote_ = std::make_unique<SideStream>(settings_.remote_side());
  remote_name_ = name;
}

void LiveCalibrationStreams::add_scalar(const std::string& name) { scalar_ = std::make_unique<LiveScalarStream>(name); }

bool LiveCalibrationStreams::push_scalar(double time_s, double value_nT) {
  if (!scalar_ || !scalar_->push(time_s, value_nT)) return false;
  // Samples before every test's next window (less the margin) are no longer needed; bounded
  // whatever the tests do: at most two windows' span behind the newest sample.
  double needed = time_s - 2.0 * settings_.window_s;
  double next = std::numeric_limits<double>::infinity();
  for (const auto& t : tests_) next = std::min(next, t->windows.next_start_s() - t->windows.period_s());
  if (std::isfinite(next)) needed = std::max(needed, next - LiveScalarStream::kMargin_s);
  scalar_->drop_before(needed);
  return true;
}

std::vector<LiveCalibrationStreams::Completed> LiveCalibrationStreams::push_remote(double time_s,
                                                                                  const Eigen::Vector3d& value_nT) {
  std::vector<Completed> out;
  if (!remote_) return out;
  remote_->push(time_s, value_nT);
  drop_remote_epochs();
  release_waiting(out);
  return out;
}

/// The waiting windows whose end the remote has reached, or that the pair has left
/// remote_max_wait_s behind (those say so), in the order they completed.
void LiveCalibrationStreams::release_waiting(std::vector<Completed>& out) {
  while (!waiting_remote_.empty()) {
    const WindowRecords& w = waiting_remote_.front().window;
    const bool reached = remote_->reached_s() >= w.end_s() - 0.25 * w.period_s;
    if (!reached && !(newest_pair_s_ - w.end_s() > settings_.remote_max_wait_s)) return;
    Waiting waiting = std::move(waiting_remote_.front());
    waiting_remote_.pop_front();  // w is gone with it: waiting.window from here
    if (!reached) {
      const double behind_s = waiting.window.end_s() - remote_->reached_s();
      char text[200];
      if (std::isfinite(behind_s)) {
        std::snprintf(text, sizeof text, "the remote had reached %.0f s before the window's end when the pair was %g s past it",
                      std::ceil(behind_s), settings_.remote_max_wait_s);
      } else {
        std::snprintf(text, sizeof text, "no remote sample had come when the pair was %g s past the window's end",
                      settings_.remote_max_wait_s);
      }
      waiting.window.remote_late = text;
    }
    finish_window(waiting.test, std::move(waiting.window), out);
  }
}

/// Forgets the remote's epochs older than every test's next window (less a period) and every
/// waiting window; bounded whatever the tests do: at most two windows' span behind its newest.
void LiveCalibrationStreams::drop_remote_epochs() {
  const double newest = remote_->newest_s();
  if (!std::isfinite(newest)) return;
  double needed = newest;
  for (const auto& t : tests_) needed = std::min(needed, t->windows.next_start_s() - 2.0 * t->windows.period_s());
  needed = std::max(needed, newest - 2.0 * settings_.window_s);
  for (const Waiting& w : waiting_remote_) needed = std::min(needed, w.window.start_s - w.window.period_s);
  remote_->drop_before(needed);
}

std::vector<LiveCalibrationStreams::Completed> LiveCalibrationStreams::push_test(std::size_t test, double time_s,
                                                                                const Eigen::Vector3d& value_nT) {
  std::vector<Completed> out;
  LiveTestStream& t = *tests_.at(test);
  StreamingDespiker::Sample s{time_s, value_nT};
  if (settings_.despike && !t.despiker.push(time_s, value_nT, s)) return out;
  newest_pair_s_ = std::max(newest_pair_s_, s.time_s);
  to_pairer(t.alignment, t.test_decimator.get(), s.time_s, s.value_nT, t.decimator_restarts,
            [&t](double time, const Eigen::Vector3d& v) { t.pairer.push_test(time, v); });
  drain(test, out);
  if (remote_) release_waiting(out);
  return out;
}

void LiveCalibrationStreams::push_temperature(std::size_t test, double time_s, double value_C) {
  tests_.at(test)->thermometer.push(time_s, value_C);
}

/// The pairs decided so far, through the decimators into the sliding window.
void LiveCalibrationStreams::drain(std::size_t test, std::vector<Completed>& out) {
  LiveTestStream& t = *tests_[test];
  const double margin = settings_.temperature_margin_s;
  const auto feed = [&](double time, const Eigen::Vector3d& r, const Eigen::Vector3d& s) {
    bool completed = false;
    for (WindowRecords& w : t.windows.push(time, r, s)) {
      if (t.temperature) w.temperature = t.thermometer.copy(w.start_s - w.period_s - margin, w.end_s() + w.period_s + margin);
      window_done(test, std::move(w), out);
      completed = true;
    }
    if (completed) t.thermometer.drop_before(t.windows.next_start_s() - t.windows.period_s() - margin);
  };
  for (const PairedSample& pair : t.pairer.take_pairs()) {
    if (t.alignment != EpochAlignment::kPairedThenDecimated) {  // at the input rate, or filtered already
      feed(pair.time_s, pair.reference_nT, pair.test_nT);
    } else {
      // A jump in the paired stamps would make the decimator emit one (NaN) output per missing
      // epoch; restart it instead (the window sees the epochs as missing either way).
      if (t.any_pair && pair.time_s - t.last_pair_s > settings_.time_jump_threshold_s) {
        t.reference_decimator->reset();
        t.test_decimator->reset();
        ++t.decimator_restarts;
      }
      const auto r = t.reference_decimator->push(pair.time_s, pair.reference_nT);
      const auto s = t.test_decimator->push(pair.time_s, pair.test_nT);
      // Both decimators see the same stamps, so they complete the same epochs.
      for (std::size_t k = 0; k < std::min(r.size(), s.size()); ++k) feed(r[k].first, r[k].second, s[k].second);
    }
    t.any_pair = true;
    t.last_pair_s = pair.time_s;
  }
}

void LiveCalibrationStreams::window_done(std::size_t test, WindowRecords&& window, std::vector<Completed>& out) {
  if (remote_) {  // its remote samples when they reach the window's end (release_waiting)
    waiting_remote_.push_back(Waiting{test, std::move(window)});
    return;
  }
  finish_window(test, std::move(window), out);
}

/// The window with its remote and scalar samples, to the per-window stage (or to its mate).
void LiveCalibrationStreams::finish_window(std::size_t test, WindowRecords&& window, std::vector<Completed>& out) {
  if (remote_) {
    auto remote = std::make_shared<VectorRecord>(
        remote_->on_epochs(window.start_s - 0.5 * window.period_s, window.end_s() + 0.5 * window.period_s));
    remote->source = remote_name_;
    window.remote = std::move(remote);
    window.remote_name = remote_name_;
  }
  if (scalar_) {
    window.scalar = scalar_->copy(window.start_s - LiveScalarStream::kMargin_s, window.end_s() + LiveScalarStream::kMargin_s);
  }
  window.decimation = tests_[test]->decimation;
  if (!coincident_) {
    out.push_back(Completed{test, std::move(window), 0});
    return;
  }
  for (CoincidentWindows::Released& r : coincident_->add(test, std::move(window))) {
    if (r.window.third) r.window.third_name = "test '" + tests_[r.mate_channel]->name + "'";
    out.push_back(Completed{r.channel, std::move(r.window), r.mate_channel});
  }
}

void LiveCalibrationStreams::restart(std::size_t test) {
  LiveTestStream& t = *tests_.at(test);
  add_counters(t.counters_before_reset, t.pairer.counters());
  t.pairer.reset();
  t.despiker.reset();
  if (t.reference_decimator) {
    t.reference_decimator->reset();
    t.test_decimator->reset();
  }
  t.windows.reset();
  waiting_remote_.erase(std::remove_if(waiting_remote_.begin(), waiting_remote_.end(),
                                       [test](const Waiting& w) { return w.test == test; }),
                        waiting_remote_.end());
  if (coincident_) coincident_->reset(test);
  t.thermometer.reset();
  t.any_pair = false;
  ++t.pipeline_resets;
}

void LiveCalibrationStreams::restart_all() {
  reference_despiker_.reset();
  if (remote_) remote_->reset();
  if (scalar_) scalar_->samples.clear();
  newest_pair_s_ = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < tests_.size(); ++i) restart(i);
}

}  // namespace magnetometer_insitu_calibration
