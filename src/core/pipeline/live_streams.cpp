// The live streams of calibration: see live_streams.hpp.
#include "magnetometer_insitu_calibration/pipeline/live_streams.hpp"

#include <algorithm>
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

}  // namespace

LiveTestStream::LiveTestStream(const std::string& test_name, bool has_temperature, const LiveStreamSettings& settings)
    : name(test_name),
      temperature(has_temperature),
      despiker(settings.despike_settings),
      pairer(settings.pairing_tolerance_s, settings.pairing_max_wait_s),
      windows(settings.window_s, settings.step_s, settings.estimation_period_s()),
      thermometer(settings.window_s + 2.0 * settings.temperature_margin_s) {
  if (settings.decimating()) {
    reference_decimator = std::make_unique<StreamingDecimator>(settings.input_period_s, settings.decimation);
    test_decimator = std::make_unique<StreamingDecimator>(settings.input_period_s, settings.decimation);
  }
}

PairingCounters LiveTestStream::counters() const {
  PairingCounters total = counters_before_reset;
  add_counters(total, pairer.counters());
  return total;
}

LiveCalibrationStreams::LiveCalibrationStreams(const LiveStreamSettings& settings,
                                               const std::vector<std::pair<std::string, bool>>& tests, bool coincident)
    : settings_(settings), reference_despiker_(settings.despike_settings) {
  for (const auto& [name, temperature] : tests) tests_.push_back(std::make_unique<LiveTestStream>(name, temperature, settings));
  if (coincident && tests_.size() >= 2) coincident_ = std::make_unique<CoincidentWindows>(tests_.size());
}

std::vector<LiveCalibrationStreams::Completed> LiveCalibrationStreams::push_reference(double time_s,
                                                                                     const Eigen::Vector3d& value_nT) {
  std::vector<Completed> out;
  StreamingDespiker::Sample s{time_s, value_nT};
  if (settings_.despike && !reference_despiker_.push(time_s, value_nT, s)) return out;
  for (std::size_t i = 0; i < tests_.size(); ++i) {
    tests_[i]->pairer.push_reference(s.time_s, s.value_nT);
    drain(i, out);
  }
  return out;
}

std::vector<LiveCalibrationStreams::Completed> LiveCalibrationStreams::push_test(std::size_t test, double time_s,
                                                                                const Eigen::Vector3d& value_nT) {
  std::vector<Completed> out;
  LiveTestStream& t = *tests_.at(test);
  StreamingDespiker::Sample s{time_s, value_nT};
  if (settings_.despike && !t.despiker.push(time_s, value_nT, s)) return out;
  t.pairer.push_test(s.time_s, s.value_nT);
  drain(test, out);
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
    if (!t.reference_decimator) {
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
  if (coincident_) coincident_->reset(test);
  t.thermometer.reset();
  t.any_pair = false;
  ++t.pipeline_resets;
}

void LiveCalibrationStreams::restart_all() {
  reference_despiker_.reset();
  for (std::size_t i = 0; i < tests_.size(); ++i) restart(i);
}

}  // namespace magnetometer_insitu_calibration
