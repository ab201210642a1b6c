// A side stream on the estimation epochs: see side_stream.hpp.
#include "magnetometer_insitu_calibration/pipeline/side_stream.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <vector>

namespace magnetometer_insitu_calibration {

namespace {

void require_period(const char* field, double period_s) {
  if (!(period_s > 0.0) || !std::isfinite(period_s)) throw InputError(field, "must be a positive time in s");
}

/// Index of the element of the time-ordered `items` nearest to time_s (ties to the earlier, as
/// align_by_time decides them); items.size() when empty.
template <typename Items, typename TimeOf>
std::size_t nearest(const Items& items, double time_s, TimeOf time_of) {
  const auto after = std::lower_bound(items.begin(), items.end(), time_s,
                                      [&](const auto& item, double t) { return time_of(item) < t; });
  if (after == items.begin()) return 0;
  const auto before = std::prev(after);
  if (after == items.end() || time_s - time_of(*before) <= time_of(*after) - time_s) {
    return static_cast<std::size_t>(before - items.begin());
  }
  return static_cast<std::size_t>(after - items.begin());
}

}  // namespace

EpochPlan SideStreamSettings::plan() const {
  return plan_epochs(reference_period_s, side_period_s, decimation.output_period_s, stamps_apart);
}

EpochAlignment SideStreamSettings::alignment() const {
  return plan().alignment == EpochAlignment::kPairedStamps ? EpochAlignment::kPairedStamps : EpochAlignment::kEachFiltered;
}

SideStream::SideStream(const SideStreamSettings& settings)
    : settings_(settings), despiker_(settings.despike_settings) {
  require_period("reference_period_s", settings.reference_period_s);
  require_period("side_period_s", settings.side_period_s);
  settings.decimation.validate();
  if (!(settings.pairing_tolerance_s >= 0.0) || !std::isfinite(settings.pairing_tolerance_s)) {
    throw InputError("pairing_tolerance_s", "must be a finite time >= 0 s");
  }
  const EpochPlan plan = settings.plan();
  period_s_ = plan.period_s;
  alignment_ = settings.alignment();
  if (alignment_ == EpochAlignment::kEachFiltered) {
    DecimationSettings d = settings.decimation;
    d.output_period_s = plan.period_s;
    filter_ = d;
    // A restart needs a step longer than the kernel's support (and an epoch).
    const double restart_gap_s = std::max(settings.time_jump_threshold_s, 2.0 * d.half_width_s() + plan.period_s);
    reference_filter_ = std::make_unique<StreamingDecimator>(settings.reference_period_s, d, restart_gap_s);
    side_filter_ = std::make_unique<StreamingDecimator>(settings.side_period_s, d, restart_gap_s);
  }
}

void SideStream::add_side(double time_s, const Eigen::Vector3d& value_nT) {
  if (!(time_s > side_reached_s_)) {
    ++rejected_at_stamps_;
    return;
  }
  side_.push_back(Epoch{time_s, value_nT});
  side_reached_s_ = time_s;
}

void SideStream::add_reference(double time_s, bool finite) {
  if (!(time_s > reference_reached_s_)) return;  // as align_by_time drops it
  reference_.emplace_back(time_s, finite);
  reference_reached_s_ = time_s;
}

void SideStream::push_reference(double time_s, const Eigen::Vector3d& value_nT) {
  if (!std::isfinite(time_s)) return;
  if (!reference_filter_) {
    add_reference(time_s, value_nT.allFinite());
    return;
  }
  for (const auto& [epoch, filtered] : reference_filter_->push(time_s, value_nT)) add_reference(epoch, filtered.allFinite());
}

void SideStream::push(double time_s, const Eigen::Vector3d& value_nT) {
  ++received_;
  StreamingDespiker::Sample s{time_s, value_nT};
  if (settings_.despike && !despiker_.push(time_s, value_nT, s)) return;
  if (!std::isfinite(s.time_s)) {
    ++rejected_at_stamps_;
    return;
  }
  filter_side(s.time_s, s.value_nT);
}

void SideStream::filter_side(double time_s, const Eigen::Vector3d& value_nT) {
  if (!side_filter_) {
    add_side(time_s, value_nT);
    return;
  }
  for (const auto& [epoch, filtered] : side_filter_->push(time_s, value_nT)) add_side(epoch, filtered);
}

void SideStream::finish() {
  if (!settings_.despike) return;
  for (const StreamingDespiker::Sample& s : despiker_.flush()) filter_side(s.time_s, s.value_nT);
}

VectorRecord SideStream::on_epochs(double low_s, double high_s) const {
  const double tolerance = settings_.pairing_tolerance_s;
  const auto time_of_side = [](const Epoch& e) { return e.time_s; };
  const auto time_of_reference = [](const std::pair<double, bool>& e) { return e.first; };
  const auto first = std::lower_bound(side_.begin(), side_.end(), low_s - tolerance,
                                      [](const Epoch& e, double t) { return e.time_s < t; });
  std::vector<double> time_s;
  std::vector<Eigen::Vector3d> values;
  for (auto it = first; !reference_.empty() && it != side_.end() && it->time_s < high_s + tolerance; ++it) {
    // The reference's epoch this sample lies on: each the other's nearest, within the tolerance
    // (filtered, both are at j * period exactly).
    const std::size_t r = nearest(reference_, it->time_s, time_of_reference);
    const double epoch = reference_[r].first;
    const auto i = static_cast<std::size_t>(it - side_.begin());
    if (std::abs(it->time_s - epoch) > tolerance || nearest(side_, epoch, time_of_side) != i) continue;
    if (epoch < low_s || epoch >= high_s) continue;
    time_s.push_back(epoch);
    // An epoch with a NaN in any component, the side's or the reference's, is missing whole.
    values.push_back(reference_[r].second && it->value_nT.allFinite()
                         ? it->value_nT
                         : Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
  }
  VectorRecord out;
  out.time_s = std::move(time_s);
  out.values_nT.resize(static_cast<Eigen::Index>(values.size()), 3);
  for (std::size_t k = 0; k < values.size(); ++k) out.values_nT.row(static_cast<Eigen::Index>(k)) = values[k].transpose();
  return out;
}

double SideStream::reached_s() const { return std::min(side_reached_s_, reference_reached_s_); }

double SideStream::newest_s() const { return std::max(side_reached_s_, reference_reached_s_); }

void SideStream::drop_before(double time_s) {
  while (!side_.empty() && side_.front().time_s < time_s) side_.pop_front();
  while (!reference_.empty() && reference_.front().first < time_s) reference_.pop_front();
}

void SideStream::reset() {
  despiker_.reset();
  if (reference_filter_) {
    reference_filter_->reset();
    side_filter_->reset();
  }
  side_.clear();
  reference_.clear();
  side_reached_s_ = reference_reached_s_ = -std::numeric_limits<double>::infinity();
}

std::size_t SideStream::rejected() const {
  return rejected_at_stamps_ + (side_filter_ ? side_filter_->rejected() : 0);
}

std::size_t SideStream::restarts() const {
  return reference_filter_ ? reference_filter_->restarts() + side_filter_->restarts() : 0;
}

}  // namespace magnetometer_insitu_calibration
