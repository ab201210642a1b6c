#include "magnetometer_insitu_calibration/preprocessing/stream_pairing.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace magnetometer_insitu_calibration {

StreamPairer::StreamPairer(double tolerance_s, double max_wait_s)
    : tolerance_s_(tolerance_s), max_wait_s_(max_wait_s) {
  if (!(tolerance_s >= 0.0) || !std::isfinite(tolerance_s)) {
    throw InputError("tolerance_s", "must be >= 0 and finite");
  }
  if (!(max_wait_s >= 0.0) || !std::isfinite(max_wait_s)) {
    throw InputError("max_wait_s", "must be >= 0 and finite");
  }
}

void StreamPairer::push_reference(double time_s, const Eigen::Vector3d& value_nT) {
  push(reference_, time_s, value_nT);
}

void StreamPairer::push_test(double time_s, const Eigen::Vector3d& value_nT) {
  push(test_, time_s, value_nT);
}

std::vector<PairedSample> StreamPairer::take_pairs() {
  std::vector<PairedSample> out;
  out.swap(ready_);
  return out;
}

void StreamPairer::flush() { match(true); }

void StreamPairer::reset() {
  reference_ = Stream{};
  test_ = Stream{};
  seen_any_ = false;
  newest_s_ = 0.0;
  ready_.clear();
  counters_ = PairingCounters{};
}

void StreamPairer::push(Stream& stream, double time_s, const Eigen::Vector3d& value_nT) {
  if (!std::isfinite(time_s)) {
    ++counters_.invalid;
    return;
  }
  if (stream.decided_any && time_s <= stream.last_decided_s) {
    ++(time_s == stream.last_decided_s ? counters_.duplicates : counters_.late);
    return;
  }
  // Usually appended at the end; a slightly out-of-order sample is inserted in place.
  auto position = std::upper_bound(stream.pending.begin(), stream.pending.end(), time_s,
                                   [](double t, const Sample& s) { return t < s.time_s; });
  if (position != stream.pending.begin() && std::prev(position)->time_s == time_s) {
    ++counters_.duplicates;
    return;
  }
  stream.pending.insert(position, Sample{time_s, value_nT});
  newest_s_ = seen_any_ ? std::max(newest_s_, time_s) : time_s;
  seen_any_ = true;
  // Pending samples of this stream more than max_wait_s ahead of this one came from a clock
  // glitch: discard them and measure waiting against the remaining stamps.
  if (stream.pending.back().time_s - time_s > max_wait_s_) {
    while (stream.pending.back().time_s - time_s > max_wait_s_) {
      stream.pending.pop_back();
      ++counters_.invalid;
    }
    newest_s_ = time_s;
    for (const Stream* s : {&reference_, &test_}) {
      if (!s->pending.empty()) newest_s_ = std::max(newest_s_, s->pending.back().time_s);
      if (s->decided_any) newest_s_ = std::max(newest_s_, s->last_decided_s);
    }
  }
  match(false);
}

void StreamPairer::drop_front(Stream& stream, std::size_t& counter) {
  ++counter;
  stream.decided_any = true;
  stream.last_decided_s = stream.pending.front().time_s;
  stream.pending.pop_front();
}

bool StreamPairer::aged(double time_s) const { return seen_any_ && newest_s_ - time_s > max_wait_s_; }

void StreamPairer::match(bool force) {
  std::deque<Sample>& refs = reference_.pending;
  std::deque<Sample>& tests = test_.pending;
  while (!refs.empty() || !tests.empty()) {
    if (refs.empty() || tests.empty()) {
      // One stream has nothing pending: its partner may still come, until it has waited too long.
      const bool ref_alone = tests.empty();
      Stream& lone = ref_alone ? reference_ : test_;
      if (!force && !aged(lone.pending.front().time_s)) return;
      drop_front(lone, ref_alone ? counters_.unpaired_reference : counters_.unpaired_test);
      continue;
    }
    const double r = refs.front().time_s;
    const double s = tests.front().time_s;
    const double d = s - r;
    if (d < -tolerance_s_) {  // s is too old for r and for every later reference
      drop_front(test_, counters_.unpaired_test);
      continue;
    }
    if (d > tolerance_s_) {  // r is too old for s and for every later test sample
      drop_front(reference_, counters_.unpaired_reference);
      continue;
    }
    const double distance = std::abs(d);
    if (refs.size() > 1 && std::abs(refs[1].time_s - s) < distance) {  // s prefers the next reference
      drop_front(reference_, counters_.unpaired_reference);
      continue;
    }
    if (tests.size() > 1 && std::abs(tests[1].time_s - r) < distance) {  // r prefers the next test
      drop_front(test_, counters_.unpaired_test);
      continue;
    }
    // A sample not received yet could still be closer: a reference in (r, 2s - r) when s > r,
    // a test sample in (s, 2r - s) when r > s. Wait for it, but not beyond max_wait_s.
    const bool may_improve = (refs.size() == 1 && s > r) || (tests.size() == 1 && r > s);
    if (may_improve && !force && !aged(std::min(r, s))) return;
    ready_.push_back(PairedSample{r, refs.front().value_nT, tests.front().value_nT});
    ++counters_.paired;
    reference_.decided_any = test_.decided_any = true;
    reference_.last_decided_s = r;
    test_.last_decided_s = s;
    refs.pop_front();
    tests.pop_front();
  }
}

}  // namespace magnetometer_insitu_calibration
