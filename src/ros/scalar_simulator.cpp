// scalar_simulator: see include/magnetometer_insitu_calibration/ros/scalar_simulator.hpp.
#include "magnetometer_insitu_calibration/ros/scalar_simulator.hpp"
#include "magnetometer_insitu_calibration/ros/si_units.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/ros/parameters.hpp"
#include "magnetometer_insitu_calibration/simulation/lemi025_station.hpp"
#include "magnetometer_insitu_calibration/simulation/scalar_magnetometer.hpp"

#include <magnetometer_insitu_calibration/ScalarField.h>

#include <cmath>
#include <stdexcept>

namespace magnetometer_insitu_calibration {

namespace {

}  // namespace

ScalarSimulatorSettings ScalarSimulatorSettings::load(const ros::NodeHandle& p) {
  ScalarSimulatorSettings s;
  s.seed = param_int(p, "seed", s.seed);
  if (s.seed < 1) throw ParameterError("seed", "must be >= 1");
  s.field_seed = param_int(p, "field_seed", s.field_seed);
  if (s.field_seed < 0) throw ParameterError("field_seed", "must be >= 0 (0: the seed)");
  s.start = param_string(p, "start", s.start);
  if (!s.start.empty()) {
    try {
      parse_iso8601(s.start);
    } catch (const std::invalid_argument& e) {
      throw ParameterError("start", e.what());
    }
  }
  s.duration_s = param_double(p, "duration", s.duration_s);
  if (!(s.duration_s >= 1.0)) throw ParameterError("duration", "must be >= 1 s");
  s.period_s = param_double(p, "period", s.period_s);
  if (!(s.period_s >= 0.1 && s.period_s <= 3600.0)) throw ParameterError("period", "must be 0.1 to 3600 s");
  s.white_nT = param_double(p, "white_nT", s.white_nT);
  if (!(s.white_nT >= 0.0)) throw ParameterError("white_nT", "must be >= 0 nT");
  s.lead_s = param_double(p, "lead", s.lead_s);
  if (!(s.lead_s >= 0.0)) throw ParameterError("lead", "must be >= 0 s");
  s.reference_topic = param_string(p, "reference_topic", s.reference_topic);
  s.scalar_topic = param_string(p, "scalar_topic", s.scalar_topic);
  s.frame_id = param_string(p, "frame_id", s.frame_id);
  return s;
}

ScalarSimulator::ScalarSimulator(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : settings_(ScalarSimulatorSettings::load(private_nh)), updater_(nh, private_nh, private_nh.getNamespace()) {
  start_s_ = settings_.start.empty() ? lemi025_live_start_s(std::floor(ros::WallTime::now().toSec()))
                                     : std::round(parse_iso8601(settings_.start));
  SimulationSettings base;
  base.seed = static_cast<std::uint64_t>(settings_.seed);
  base.field_seed = static_cast<std::uint64_t>(settings_.field_seed);
  SimulationSettings s = lemi025_station_settings(base, start_s_, settings_.duration_s, kLemi025StationVariationRms_nT);
  s.keep_clean_field = true;
  ScalarMagnetometerSettings m;
  m.seed = base.seed + 500;  // the scalar's own noise, not the pair's
  m.period_s = settings_.period_s;
  m.white_nT = settings_.white_nT;
  try {  // validates m
    record_ = simulate_scalar_magnetometer(simulate_pair(s), m);
  } catch (const InputError& e) {
    throw ParameterError(e.where(), e.problem());
  }
  if (record_.size() == 0) throw ParameterError("duration", "holds no scalar sample");
  publisher_ = nh.advertise<ScalarField>(settings_.scalar_topic, 100);
  subscriber_ = nh.subscribe(settings_.reference_topic, 100, &ScalarSimulator::on_reference, this,
                             ros::TransportHints().tcpNoDelay());
  updater_.setHardwareID("simulated scalar magnetometer");
  updater_.add("scalar", [this](diagnostic_updater::DiagnosticStatusWrapper& st) { diagnose(st); });
  ROS_INFO("%s: F every %g s from %s (seed %d), paced by %s, on %s", private_nh.getNamespace().c_str(),
           settings_.period_s, format_iso8601(start_s_, 0).c_str(), settings_.seed,
           nh.resolveName(settings_.reference_topic).c_str(), nh.resolveName(settings_.scalar_topic).c_str());
}

void ScalarSimulator::on_reference(const sensor_msgs::MagneticField::ConstPtr& message) {
  const double t = message->header.stamp.toSec();
  const std::uint64_t size = record_.size();
  const double pass_s = std::ceil(settings_.duration_s);
  const auto stamp_of = [&](std::uint64_t j) {
    return record_.time_s[static_cast<std::size_t>(j % size)] + static_cast<double>(j / size) * pass_s;
  };
  if (references_++ == 0) {  // a live station starts mid-record: F from a lead before its first sample
    const double passes = std::max(0.0, std::floor((t - settings_.lead_s - start_s_) / pass_s));
    next_ = static_cast<std::uint64_t>(passes) * size;
    while (stamp_of(next_) < t - settings_.lead_s) ++next_;
  }
  for (; stamp_of(next_) <= t + settings_.lead_s; ++next_) {
    const double f = record_.value_nT[static_cast<std::size_t>(next_ % size)];
    if (!std::isfinite(f)) continue;
    ScalarField out;
    out.header.stamp = ros::Time(stamp_of(next_));
    out.header.frame_id = settings_.frame_id;
    out.field = kTeslaPerNanotesla * f;
    out.variance = std::pow(kTeslaPerNanotesla * settings_.white_nT, 2);
    publisher_.publish(out);
    ++published_;
    last_stamp_s_ = stamp_of(next_);
  }
  updater_.update();
}

void ScalarSimulator::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  if (references_ == 0) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "waiting for the reference's first sample");
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "publishing F");
  }
  status.add("samples published", published_);
  status.add("newest stamp", published_ > 0 ? format_iso8601(last_stamp_s_, 3) : std::string("none"));
  status.add("reference samples seen", references_);
  status.add("period (s)", settings_.period_s);
}

}  // namespace magnetometer_insitu_calibration
