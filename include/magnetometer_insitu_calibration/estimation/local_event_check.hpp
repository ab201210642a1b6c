// Without a remote: does the reference carry local events that the test does not follow as it
// follows the field? A window's check, run by the default estimator on the pair alone.
//
// Why. A disturbance both sensors see with different gains and directions (a vehicle on a road
// beside the hut, a machine), or the reference alone, biases n, and nothing the pair does inside
// the band tells it from the field (remote_reference.hpp). Above the band it can be seen: a
// vehicle arriving, passing or leaving is an event of seconds to minutes, strong at 0.02-0.2 Hz
// where the natural field is weak, and it reaches T - R H(f) (H the pair's transfer there)
// because the test does not see it as R H(f). A parked car's field inside the band is the same
// dipole seen the same way, so events above the band are the pair's evidence that such a
// disturbance is there.
//
// How (units nT, s, Hz). The event band is [f1, f2], f1 = max(0.02 Hz, 2 x the estimation
// band's top), f2 = min(10 f1, 0.4 / period). Where f2 is at most 0.4 of the Nyquist frequency of
// the records averaged in pairs of samples (at 1 s), the check reads those averages (the same
// linear filter on R and T, half the work). Both records are differenced (each value's change:
// the same linear filter again, which lowers the band's strong red field by f^2 so that a taper's
// sidelobes cannot carry it into the event band) and cut into blocks of 2.56 / f1 s (128 s at
// f1 = 0.02 Hz, a power of two of values), the test's blocks shifted by the window's delay to the
// nearest value; each block less its mean is Hann-tapered and transformed. A block holding a
// straight-line run in every column (a gap or a screened run the pipeline filled in both records)
// is left out: its energies would be low in R and in E together. At each harmonic of the event
// band, H is the complex 3 x 3 least-squares transfer of T on R over every block (any response,
// filter or delay of the test is linear and time-invariant: H takes it), and each block's
// residual is E = T - R H. Per block: the reference's energy in the lower half of the event band
// and the residual's in the upper half, and the other way round (halves at sqrt(f1 f2)).
// Instrument noise in disjoint frequencies is independent, so the reference's own noise, which
// is in both R and E, cannot correlate them; an event is broadband and raises both. Each energy's
// logarithm less its running median over 31 blocks (about an hour) keeps only what changes from
// one block to the next: a station's day (more geomagnetic activity, more cultural noise at noon)
// would otherwise correlate them with no event. Spearman's rank correlation of each pair of
// series, z_k = rho_k sqrt(K - 1) over K blocks, z = (z_1 + z_2) / sqrt(2), one-sided p from the
// normal tail; events are seen at p < 0.01 (the level of the package's other checks between
// estimates).
//
// What it cannot see: events with no energy above the band (a car parked before the window and
// still there), and it says nothing of how far they moved n; a seen window is "not vouched for":
// give a remote reference. Disturbances of the test alone do not raise R and are not seen (they
// are noise in the response, not a bias). Fewer than 64 blocks (2.3 h at 1 s), or an event band
// narrower than a factor 4: not assessed. Measured false calls and detections: docs/accuracy.md,
// "Remote reference".
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <Eigen/Core>

#include <limits>
#include <string>

namespace magnetometer_insitu_calibration {

/// Level of the local-event check (one-sided).
constexpr double kLocalEventAlpha = 0.01;

/// What the local-event check found in a window (see above).
struct LocalEventCheck {
  bool assessed = false;
  double z = std::numeric_limits<double>::quiet_NaN();        ///< (z_1 + z_2) / sqrt(2)
  double p_value = std::numeric_limits<double>::quiet_NaN();  ///< one-sided, normal tail
  bool seen = false;   ///< events at p < kLocalEventAlpha: the pair-only window is not vouched for
  double low_hz = std::numeric_limits<double>::quiet_NaN();   ///< event band used, Hz
  double high_hz = std::numeric_limits<double>::quiet_NaN();
  int blocks = 0;      ///< K
  std::string text;    ///< what was found, or why not assessed
};

/// The check on a window's records: reference_nT and test_nT N x 3 (nT; reference and test
/// frames), regular sample period (s), no NaN; band_high_hz the top of the estimation band;
/// delay_s the test's delay against the reference (NaN: none known), taken to the nearest sample.
LocalEventCheck check_local_events(const Eigen::Ref<const Readings>& reference_nT,
                                   const Eigen::Ref<const Readings>& test_nT, double sample_period_s,
                                   double band_high_hz, double delay_s);

}  // namespace magnetometer_insitu_calibration
