// Simulator of two co-located three-component magnetometers with known truth: a reference and
// a test instrument recording the same geomagnetic field, for testing the calibration chain.
//
// Model (rows are samples i at times t_i = start_time_s + i * sample_period_s, UNIX s UTC):
//   B(t)  = main_field + daily(t) + variations(t)                 reference frame, nT
//   R_i   = B(t_i) + noise_r,i (+ spikes, gaps)                    reference frame, nT
//   T_i   = B(t_i - delay_s) n(t_i) + offset + drift (t_i - start) + noise_t,i (+ spikes, gaps)
//                                                                  test frame, nT
// with n(t) = exp([w]x (t - t_mid)) n_true (tilt drift, w = axis * rate; n(t_mid) = n_true,
// t_mid the middle of the record), so that without tilt, delay and noise T = R n_true + drift.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// Which instrument an artefact (spike, gap) goes to.
enum class SimulatedInstrument : int {
  kReference = 0,
  kTest = 1,
  kEither = 2,  ///< settings only: each event goes to one of the two, drawn at random
  kBoth = 3,    ///< the same samples of both instruments
};
const char* simulated_instrument_name(SimulatedInstrument instrument);  ///< "reference", ...
/// Parses "reference", "test", "either", "both"; throws InputError(where, ...) otherwise.
SimulatedInstrument parse_simulated_instrument(const std::string& text, const std::string& where);

struct SimulationSettings {
  // --- Time base ------------------------------------------------------------------------------
  double start_time_s = 1747180800.0;  ///< UNIX s UTC of sample 0 (2025-05-14T00:00:00Z)
  double duration_s = 86400.0;         ///< s; samples = round(duration_s / sample_period_s)
  double sample_period_s = 1.0;        ///< s (1.0 for 1 Hz, 0.1 for 10 Hz)
  std::uint64_t seed = 1;              ///< same seed and settings -> identical output
  /// Seed of the field's variations alone; 0: `seed`. Two stations with one field_seed and their
  /// own seeds see one field through independent instruments, noise and disturbances: each is
  /// the other's remote reference (a network of stations on one master).
  std::uint64_t field_seed = 0;

  // --- Geomagnetic field B in the reference frame ----------------------------------------------
  /// Constant (main) field, nT, reference x, y, z (default: mid-latitude Europe).
  Eigen::Vector3d main_field_nT{21500.0, 500.0, 43000.0};
  /// Power-law variations, one-sided PSD proportional to (f^2 + corner^2)^(-spectral_index/2),
  /// synthesised in the frequency domain (zero mean, no Nyquist harmonic).
  double spectral_index = 2.0;         ///< dimensionless, PSD ~ f^-spectral_index
  double variation_corner_hz = 0.0;    ///< Hz, spectrum flat below (0: pure power law)
  double variation_rms_nT = 5.0;       ///< nT, rms of the x and y variations over the record
  double variation_z_ratio = 0.4;      ///< rms of z variations / variation_rms_nT
  /// Correlation coefficients xy, xz, yz of the variations. The sample covariance over the
  /// record is made exactly diag(rms) C diag(rms): rms and correlations are exact, not expected.
  Eigen::Vector3d variation_correlation{0.3, 0.2, 0.1};
  /// Daily (Sq-like) variation: amplitude of the 24 h harmonic, nT, per reference component;
  /// the 12 h and 8 h harmonics have daily_harmonic_weights[1], [2] times it. A function of UTC
  /// time of day (fixed phases), zero mean over whole days.
  Eigen::Vector3d daily_amplitude_nT{20.0, 10.0, 10.0};
  std::array<double, 3> daily_harmonic_weights{1.0, 0.5, 0.25};  ///< 24 h, 12 h, 8 h

  // --- Test instrument: calibration matrix ----------------------------------------------------
  /// K_test,l / K_ref,l (dimensionless), as in Marusenkov et al. (2011).
  Eigen::Vector3d scale_ratio{0.9996, 1.0004, 1.0004};
  /// xy, xz, yz: 90 deg minus the angle between test axes, degrees.
  Eigen::Vector3d nonorthogonality_deg{0.01, 0.0, 0.02};
  /// Rotation vector of the reference-to-test rotation, degrees, about reference x, y, z.
  Eigen::Vector3d misalignment_deg{0.05, -0.1, 0.3};
  /// If set, n_true = n_explicit and the three angle/scale fields above are ignored.
  std::optional<Eigen::Matrix3d> n_explicit;

  // --- Instrument noise (reference noise in the reference frame, test noise in the test frame) -
  double reference_white_nT = 0.01;   ///< nT rms per sample, white
  double test_white_nT = 0.01;        ///< nT rms per sample, white
  /// Pink (1/f) noise: amplitude spectral density at 1 Hz, nT/sqrt(Hz); one-sided PSD =
  /// level^2 / f over the record's harmonics (no mean, no Nyquist harmonic).
  double reference_pink_nT_per_sqrt_hz = 0.005;
  double test_pink_nT_per_sqrt_hz = 0.005;

  // --- Test instrument: baseline, drift, tilt, delay ------------------------------------------
  Eigen::Vector3d test_offset_nT = Eigen::Vector3d::Zero();   ///< nT, test frame, constant
  Eigen::Vector3d drift_nT_per_day = Eigen::Vector3d::Zero();  ///< nT/day, test frame, from start
  /// Tilt drift: the test axes rotate about tilt_axis (reference frame, any length but zero)
  /// at tilt_rate_deg_per_day, referred to the middle of the record (n(t_mid) = n_true).
  Eigen::Vector3d tilt_axis{0.0, 1.0, 0.0};
  double tilt_rate_deg_per_day = 0.0;
  /// Test samples see the field at t - delay_s (s, may be fractional or negative): exact
  /// phase shift of the variations, daily variation evaluated at t - delay_s.
  double delay_s = 0.0;

  // --- Artefacts -------------------------------------------------------------------------------
  /// Spikes: exactly round(spikes_per_day * duration_s / 86400) one-sample spikes, each in one
  /// random component, sign random, size spike_amplitude_nT; never inside a gap, never two at
  /// the same sample.
  double spikes_per_day = 0.0;
  double spike_amplitude_nT = 50.0;   ///< nT
  SimulatedInstrument spike_instrument = SimulatedInstrument::kEither;
  /// Gaps: exactly gap_count runs of round(gap_length_s / sample_period_s) (>= 1) samples with
  /// all three components NaN (times kept), at random places, separated by >= 1 valid sample.
  int gap_count = 0;
  double gap_length_s = 600.0;        ///< s
  SimulatedInstrument gap_instrument = SimulatedInstrument::kEither;

  /// Keep the clean field B (field_nT, field_delayed_nT) in the result (tests); the CLI does not.
  bool keep_clean_field = true;

  /// Number of samples, round(duration_s / sample_period_s).
  std::size_t samples() const;
  /// n_true from n_explicit or from the angles (matrix_from_angles).
  Eigen::Matrix3d n_true() const;
  /// Throws InputError whose where() is the field name (e.g. "sample_period_s") for an
  /// impossible value.
  void validate() const;
};

struct SimulatedSpike {
  std::size_t index = 0;  ///< sample index
  SimulatedInstrument instrument = SimulatedInstrument::kTest;  ///< kReference, kTest or kBoth
  int component = 0;      ///< 0, 1, 2 (x, y, z of that instrument's frame)
  double amplitude_nT = 0.0;  ///< signed value added
};

struct SimulatedGap {
  std::size_t first_index = 0;  ///< first NaN sample
  std::size_t length = 0;       ///< samples
  SimulatedInstrument instrument = SimulatedInstrument::kTest;  ///< kReference, kTest or kBoth
};

struct SimulatedPair {
  VectorRecord reference;  ///< R, reference frame, nT
  VectorRecord test;       ///< T, test frame, nT
  Eigen::Matrix3d n_true = Eigen::Matrix3d::Identity();  ///< T = R n_true at t_mid
  /// The set linear drift of T (nT/day, test frame): the estimator's trend column.
  Eigen::Vector3d trend_nT_per_day = Eigen::Vector3d::Zero();
  /// Linear drift produced by the tilt through the mean field: mean(B) [w]x n_true, nT/day
  /// (first order in the tilt angle). Zero without tilt.
  Eigen::Vector3d tilt_trend_nT_per_day = Eigen::Vector3d::Zero();
  /// Clean field B(t_i) and B(t_i - delay_s), N x 3, reference frame, nT (empty unless
  /// keep_clean_field).
  Readings field_nT;
  Readings field_delayed_nT;
  std::vector<SimulatedSpike> spikes;  ///< sorted by index
  std::vector<SimulatedGap> gaps;      ///< sorted by first_index
  // Tilt model, to evaluate n(t):
  double tilt_reference_time_s = 0.0;  ///< t_mid, UNIX s
  Eigen::Vector3d tilt_rate_rad_per_s = Eigen::Vector3d::Zero();  ///< w, reference frame

  /// n(t) = exp([w]x (t - t_mid)) n_true, the calibration matrix in force at time t.
  Eigen::Matrix3d n_at(double time_s) const;
};

/// Simulates the pair. Deterministic for given settings (including seed); independent random
/// streams for variations, each instrument's noise, spikes and gaps. Throws InputError (from
/// validate()) for impossible settings. Uses FFTW (c2r) for the spectral parts.
SimulatedPair simulate_pair(const SimulationSettings& settings);

/// truth.json text: {"n_true": [9 numbers, row-major], "trend_nT_per_day", "tilt_trend_nT_per_day",
/// "spikes": [...], "gaps": [...], "settings": {...every SimulationSettings field...}}.
std::string simulation_truth_json(const SimulationSettings& settings, const SimulatedPair& pair,
                                  int indent = 2);

}  // namespace magnetometer_insitu_calibration
