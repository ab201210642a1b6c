// Disturbances of a disturbed station added to a simulated pair: see station_disturbances.hpp.
#include "magnetometer_insitu_calibration/simulation/station_disturbances.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <cmath>
#include <random>

namespace magnetometer_insitu_calibration {

void StationDisturbanceSettings::validate() const {
  auto range = [](double lo, double hi, const char* field) {
    if (!(lo > 0.0) || !(hi >= lo) || !std::isfinite(hi)) throw InputError(field, "needs 0 < min <= max, finite");
  };
  if (!(vehicles_per_day >= 0.0) || !std::isfinite(vehicles_per_day)) throw InputError("vehicles_per_day", "must be >= 0");
  if (!(road_distance_m > 0.5) || !std::isfinite(road_distance_m)) throw InputError("road_distance_m", "must be > 0.5 m");
  if (!test_sensor_offset_m.allFinite()) throw InputError("test_sensor_offset_m", "must be finite");
  range(moment_min_Am2, moment_max_Am2, "moment_min_Am2");
  range(speed_min_m_per_s, speed_max_m_per_s, "speed_min_m_per_s");
  if (!(parking_probability >= 0.0 && parking_probability <= 1.0)) throw InputError("parking_probability", "must be in [0, 1]");
  range(parking_min_s, parking_max_s, "parking_min_s");
  if (!(small_spikes_per_day >= 0.0) || !std::isfinite(small_spikes_per_day)) throw InputError("small_spikes_per_day", "must be >= 0");
  range(small_spike_min_nT, small_spike_max_nT, "small_spike_min_nT");
  if (steps < 0) throw InputError("steps", "must be >= 0");
  range(step_min_nT, step_max_nT, "step_min_nT");
}

namespace {

/// Dipole field (nT) at offset r (m) from a dipole m (A m^2): 1e-7 (3 (m.r^) r^ - m) / r^3 T.
Eigen::Vector3d dipole_nT(const Eigen::Vector3d& m, const Eigen::Vector3d& r) {
  const double d = r.norm();
  const Eigen::Vector3d u = r / d;
  return 1e-7 * 1e9 * (3.0 * m.dot(u) * u - m) / (d * d * d);
}

}  // namespace

StationDisturbanceReport add_station_disturbances(SimulatedPair& pair, const StationDisturbanceSettings& s) {
  s.validate();
  std::mt19937_64 rng(s.seed * 0x9E3779B97F4A7C15ULL + 12345);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> normal;
  auto log_uniform = [&](double lo, double hi) { return lo * std::pow(hi / lo, uniform(rng)); };
  const std::size_t n = pair.reference.size();
  const double dt = n > 1 ? pair.reference.time_s[1] - pair.reference.time_s[0] : 1.0;
  const double days = static_cast<double>(n) * dt / 86400.0;
  StationDisturbanceReport report;
  report.reference_added_nT = Readings::Zero(static_cast<Eigen::Index>(n), 3);
  report.test_added_nT = Readings::Zero(static_cast<Eigen::Index>(n), 3);
  Readings test_field_added = Readings::Zero(static_cast<Eigen::Index>(n), 3);  // reference frame

  // Vehicles: road along unit vector u through the closest point c (distance d from the reference).
  const double az = s.road_azimuth_deg * M_PI / 180.0;
  const Eigen::Vector3d along(std::cos(az), std::sin(az), 0.0);
  const Eigen::Vector3d across(-std::sin(az), std::cos(az), 0.0);
  const Eigen::Vector3d closest = s.road_distance_m * across + Eigen::Vector3d(0.0, 0.0, s.road_height_m);
  const std::size_t vehicles = static_cast<std::size_t>(std::llround(s.vehicles_per_day * days));
  for (std::size_t v = 0; v < vehicles; ++v) {
    const double t0 = uniform(rng) * static_cast<double>(n) * dt;  // s from the start: passes c
    Eigen::Vector3d m(normal(rng), normal(rng), normal(rng));
    m = m.normalized() * log_uniform(s.moment_min_Am2, s.moment_max_Am2);
    const double speed = s.speed_min_m_per_s + uniform(rng) * (s.speed_max_m_per_s - s.speed_min_m_per_s);
    const bool parks = uniform(rng) < s.parking_probability;
    const double dwell = parks ? log_uniform(s.parking_min_s, s.parking_max_s) : 0.0;
    const double direction = uniform(rng) < 0.5 ? -1.0 : 1.0;
    report.parked += parks;
    // Affects the sensors within ~ 30 road distances (field below 1/27000 of the peak).
    const double reach_s = 30.0 * s.road_distance_m / speed;
    const long first = std::max(0L, static_cast<long>(std::floor((t0 - reach_s) / dt)));
    const long last = std::min(static_cast<long>(n) - 1, static_cast<long>(std::ceil((t0 + dwell + reach_s) / dt)));
    for (long i = first; i <= last; ++i) {
      const double t = static_cast<double>(i) * dt;
      double x;  // position along the road from c, m
      if (t < t0) x = (t - t0) * speed;
      else if (t < t0 + dwell) x = 0.0;
      else x = (t - t0 - dwell) * speed;
      const Eigen::Vector3d position = closest + direction * x * along;
      const Eigen::Vector3d b_ref = dipole_nT(m, position);
      const Eigen::Vector3d b_test = dipole_nT(m, position - s.test_sensor_offset_m);
      report.reference_added_nT.row(i) += b_ref.transpose();
      test_field_added.row(i) += b_test.transpose();
      report.max_vehicle_reference_nT = std::max(report.max_vehicle_reference_nT, b_ref.norm());
      report.max_vehicle_test_nT = std::max(report.max_vehicle_test_nT, b_test.norm());
    }
  }
  report.vehicles = vehicles;
  // The test sensor reads the extra field through its calibration matrix, in its own frame.
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Index r = static_cast<Eigen::Index>(i);
    if (test_field_added.row(r).isZero()) continue;
    report.test_added_nT.row(r) = test_field_added.row(r) * pair.n_at(pair.test.time_s[i]);
  }

  auto pick = [&](SimulatedInstrument which) {
    if (which == SimulatedInstrument::kEither) return uniform(rng) < 0.5 ? SimulatedInstrument::kReference : SimulatedInstrument::kTest;
    return which;
  };
  // Small spikes: runs of 1..3 samples.
  const std::size_t spikes = static_cast<std::size_t>(std::llround(s.small_spikes_per_day * days));
  for (std::size_t k = 0; k < spikes; ++k) {
    const std::size_t at = std::min(n - 1, static_cast<std::size_t>(uniform(rng) * static_cast<double>(n)));
    const std::size_t run = 1 + static_cast<std::size_t>(uniform(rng) * 3.0) % 3;
    const int component = static_cast<int>(uniform(rng) * 3.0) % 3;
    const double amplitude = (uniform(rng) < 0.5 ? -1.0 : 1.0) * log_uniform(s.small_spike_min_nT, s.small_spike_max_nT);
    const SimulatedInstrument which = pick(s.small_spike_instrument);
    for (std::size_t i = at; i < std::min(n, at + run); ++i) {
      const Eigen::Index r = static_cast<Eigen::Index>(i);
      if (which != SimulatedInstrument::kTest) report.reference_added_nT(r, component) += amplitude;
      if (which != SimulatedInstrument::kReference) report.test_added_nT(r, component) += amplitude;
    }
  }
  report.small_spikes = spikes;
  // Steps.
  for (int k = 0; k < s.steps; ++k) {
    const std::size_t at = std::min(n - 1, static_cast<std::size_t>(uniform(rng) * static_cast<double>(n)));
    const int component = static_cast<int>(uniform(rng) * 3.0) % 3;
    const double amplitude = (uniform(rng) < 0.5 ? -1.0 : 1.0) * log_uniform(s.step_min_nT, s.step_max_nT);
    const SimulatedInstrument which = pick(s.step_instrument);
    const Eigen::Index first = static_cast<Eigen::Index>(at), count = static_cast<Eigen::Index>(n - at);
    if (which != SimulatedInstrument::kTest) report.reference_added_nT.col(component).segment(first, count).array() += amplitude;
    if (which != SimulatedInstrument::kReference) report.test_added_nT.col(component).segment(first, count).array() += amplitude;
  }
  report.steps = static_cast<std::size_t>(s.steps);
  pair.reference.values_nT += report.reference_added_nT;  // NaN + x stays NaN
  pair.test.values_nT += report.test_added_nT;
  return report;
}

}  // namespace magnetometer_insitu_calibration
