// truth.json of a simulation: see simulation_truth_json in simulator.hpp.
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <nlohmann/json.hpp>

namespace magnetometer_insitu_calibration {
namespace {

nlohmann::json vector_json(const Eigen::Vector3d& v) { return {v(0), v(1), v(2)}; }

nlohmann::json row_major_json(const Eigen::Matrix3d& m) {
  nlohmann::json out = nlohmann::json::array();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out.push_back(m(r, c));
  return out;
}

}  // namespace

std::string simulation_truth_json(const SimulationSettings& s, const SimulatedPair& pair,
                                  int indent) {
  nlohmann::json settings = {
      {"start_time_s", s.start_time_s},
      {"duration_s", s.duration_s},
      {"sample_period_s", s.sample_period_s},
      {"samples", s.samples()},
      {"seed", s.seed},
      {"main_field_nT", vector_json(s.main_field_nT)},
      {"spectral_index", s.spectral_index},
      {"variation_corner_hz", s.variation_corner_hz},
      {"variation_rms_nT", s.variation_rms_nT},
      {"variation_z_ratio", s.variation_z_ratio},
      {"variation_correlation_xy_xz_yz", vector_json(s.variation_correlation)},
      {"daily_amplitude_nT", vector_json(s.daily_amplitude_nT)},
      {"daily_harmonic_weights_24h_12h_8h",
       {s.daily_harmonic_weights[0], s.daily_harmonic_weights[1], s.daily_harmonic_weights[2]}},
      {"scale_ratio", vector_json(s.scale_ratio)},
      {"nonorthogonality_deg_xy_xz_yz", vector_json(s.nonorthogonality_deg)},
      {"misalignment_deg", vector_json(s.misalignment_deg)},
      {"n_explicit", s.n_explicit ? row_major_json(*s.n_explicit) : nlohmann::json(nullptr)},
      {"reference_white_nT", s.reference_white_nT},
      {"test_white_nT", s.test_white_nT},
      {"reference_pink_nT_per_sqrt_hz", s.reference_pink_nT_per_sqrt_hz},
      {"test_pink_nT_per_sqrt_hz", s.test_pink_nT_per_sqrt_hz},
      {"test_offset_nT", vector_json(s.test_offset_nT)},
      {"drift_nT_per_day", vector_json(s.drift_nT_per_day)},
      {"tilt_axis", vector_json(s.tilt_axis)},
      {"tilt_rate_deg_per_day", s.tilt_rate_deg_per_day},
      {"delay_s", s.delay_s},
      {"spikes_per_day", s.spikes_per_day},
      {"spike_amplitude_nT", s.spike_amplitude_nT},
      {"spike_instrument", simulated_instrument_name(s.spike_instrument)},
      {"gap_count", s.gap_count},
      {"gap_length_s", s.gap_length_s},
      {"gap_instrument", simulated_instrument_name(s.gap_instrument)},
  };
  nlohmann::json spikes = nlohmann::json::array();
  for (const auto& spike : pair.spikes) {
    spikes.push_back({{"index", spike.index},
                      {"time_s", s.start_time_s + static_cast<double>(spike.index) * s.sample_period_s},
                      {"instrument", simulated_instrument_name(spike.instrument)},
                      {"component", spike.component},
                      {"amplitude_nT", spike.amplitude_nT}});
  }
  nlohmann::json gaps = nlohmann::json::array();
  for (const auto& gap : pair.gaps) {
    gaps.push_back(
        {{"first_index", gap.first_index},
         {"length", gap.length},
         {"first_time_s", s.start_time_s + static_cast<double>(gap.first_index) * s.sample_period_s},
         {"instrument", simulated_instrument_name(gap.instrument)}});
  }
  nlohmann::json truth = {
      {"convention", "T = R n (rows are samples); column l of n = test axis l in reference frame"},
      {"n_true", row_major_json(pair.n_true)},
      {"trend_nT_per_day", vector_json(pair.trend_nT_per_day)},
      {"tilt_trend_nT_per_day", vector_json(pair.tilt_trend_nT_per_day)},
      {"tilt_reference_time_s", pair.tilt_reference_time_s},
      {"spikes", spikes},
      {"gaps", gaps},
      {"settings", settings},
  };
  return truth.dump(indent);
}

}  // namespace magnetometer_insitu_calibration
