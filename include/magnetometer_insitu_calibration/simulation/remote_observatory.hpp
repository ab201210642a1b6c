// A remote observatory beside a simulated pair (simulator.hpp): what a neighbouring INTERMAGNET
// station or another station of a network records at the pair's epochs, for the remote
// reference (estimation/remote_reference.hpp).
//
// Model (rows are samples, nT): the remote sees the geomagnetic variations of the pair's field,
// a share of whose variance is its own (source-field structure and induction differ over
// hundreds of kilometres), through its own orientation and response, plus its own noise:
//   F_remote = main + daily + sqrt(1 - f_k) V + sqrt(f_k) V'   (column k; f = incoherent_fraction for
//                                                               x and y, z_incoherent_fraction for z)
//   C = F_remote Q + noise,   Q = rotation(rotation_deg) diag(gain) + z_from_x e_x e_z^T
// V the pair's variations (its clean field minus main field and daily variation), V' an
// independent realisation with the same spectrum and correlations. With a finite
// coherence_corner_hz the remote's own share grows with frequency nu, as between real stations
// (shorter periods, smaller source and induction scales): the mixing is made at each harmonic with
// f_k(nu) = 1 - (1 - f_k) exp(-nu / coherence_corner_hz) in place of f_k (at 0.05 Hz and a share of 0.2: 0.35 at 0.01 Hz, 0.46 at 0.02 Hz, 0.71 at
// the corner). Q any real 3 x 3 (the remote
// needs no calibration: n from it is exactly unchanged by Q). The remote's stamps are the pair's
// plus time_offset_s (a wrong time base), its gaps NaN runs of its own. It sees none of the
// pair's local disturbances.
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <limits>

namespace magnetometer_insitu_calibration {

struct RemoteObservatorySettings {
  std::uint64_t seed = 1;
  /// Share of the horizontal (x, y) variations' variance that is the remote's own, [0, 1).
  double incoherent_fraction = 0.2;
  /// The same for the vertical, [0, 1). Z is the more local component (induction in the ground
  /// under each station, a coast, a conductor), so between real stations its own share is often
  /// the larger one.
  double z_incoherent_fraction = 0.2;
  /// Frequency at which the remote's own share has risen to 1 - (1 - incoherent_fraction) / e, Hz;
  /// infinite: the same share at every frequency.
  double coherence_corner_hz = std::numeric_limits<double>::infinity();
  Eigen::Vector3d rotation_deg{0.0, 0.0, 25.0};  ///< rotation vector of its axes, degrees
  Eigen::Vector3d gain{1.0, 1.0, 0.7};           ///< per axis (its Z responds differently)
  double z_from_x = 0.1;                         ///< its Z also reads this share of x
  double white_nT = 0.01;                        ///< nT rms per sample, white
  double pink_nT_per_sqrt_hz = 0.005;            ///< ASD at 1 Hz, one-sided PSD = level^2 / f
  double time_offset_s = 0.0;  ///< its stamps minus the true times, s (a wrong time base)
  int gap_count = 0;           ///< NaN runs of gap_length_s at random places
  double gap_length_s = 600.0;

  void validate() const;  ///< throws InputError naming the field
};

/// The remote's record at the pair's epochs (plus time_offset_s), its own frame, nT. `local`: the
/// settings the pair was simulated with (with keep_clean_field, as pair.field_nT needs).
/// Deterministic for a given seed. Throws InputError for impossible settings or a pair without
/// its clean field.
VectorRecord simulate_remote_observatory(const SimulationSettings& local, const SimulatedPair& pair,
                                         const RemoteObservatorySettings& settings);

/// The mixing Q of the settings (reference frame of the pair -> the remote's readings, rows).
Eigen::Matrix3d remote_mixing(const RemoteObservatorySettings& settings);

}  // namespace magnetometer_insitu_calibration
