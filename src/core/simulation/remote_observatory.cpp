// A remote observatory's record beside a simulated pair: see remote_observatory.hpp.
#include "magnetometer_insitu_calibration/simulation/remote_observatory.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/estimation/calibration_matrix.hpp"
#include "magnetometer_insitu_calibration/estimation/column_response.hpp"
#include "magnetometer_insitu_calibration/simulation/power_law_noise.hpp"

#include <cmath>
#include <string>

namespace magnetometer_insitu_calibration {

namespace {

/// The pair's settings for a field without instruments: no noise, spikes, gaps, tilt or delay.
SimulationSettings clean_field_settings(const SimulationSettings& local) {
  SimulationSettings s = local;
  s.reference_white_nT = s.test_white_nT = 0.0;
  s.reference_pink_nT_per_sqrt_hz = s.test_pink_nT_per_sqrt_hz = 0.0;
  s.spikes_per_day = 0.0;
  s.gap_count = 0;
  s.tilt_rate_deg_per_day = 0.0;
  s.delay_s = 0.0;
  s.keep_clean_field = true;
  return s;
}

/// sqrt(1 - f(nu)) shared + sqrt(f(nu)) own, column by column, with the remote's own share
/// f(nu) = 1 - (1 - f0_c) exp(-nu / corner_hz) at each harmonic nu of the record (nT, no NaN;
/// dt in s). Each column is filtered without a wrap-around step (column_response.hpp); its line
/// through the first and last samples, the lowest frequencies, is weighted as at nu = 0.
Readings mix_by_frequency(const Readings& shared, const Readings& own, const Eigen::Vector3d& f0, double corner_hz,
                          double dt) {
  const Eigen::Index rows = shared.rows();
  ColumnResponse filter(static_cast<std::size_t>(rows));
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(rows, 0.0, 1.0);  // the line's abscissa
  Readings out(rows, 3);
  Eigen::VectorXd part(rows);
  for (int c = 0; c < 3; ++c) {
    auto own_share = [&](double nu) { return 1.0 - (1.0 - f0(c)) * std::exp(-nu / corner_hz); };
    for (int which = 0; which < 2; ++which) {  // the pair's field, then the remote's own
      const auto v = (which == 0 ? shared : own).col(c);
      const auto weight = [&](double nu) { return std::sqrt(which == 0 ? 1.0 - own_share(nu) : own_share(nu)); };
      filter.apply(v, dt, weight, 0.0, part);  // puts the line back whole: take off what it lacks of weight(0)
      part -= (1.0 - weight(0.0)) * (v(0) + (v(rows - 1) - v(0)) * t.array()).matrix();
      if (which == 0) {
        out.col(c) = part;
      } else {
        out.col(c) += part;
      }
    }
  }
  return out;
}

}  // namespace

void RemoteObservatorySettings::validate() const {
  auto require = [](bool ok, const char* field, const std::string& problem) {
    if (!ok) throw InputError(field, problem);
  };
  require(incoherent_fraction >= 0.0 && incoherent_fraction < 1.0, "incoherent_fraction", "must be in [0, 1)");
  require(z_incoherent_fraction >= 0.0 && z_incoherent_fraction < 1.0, "z_incoherent_fraction", "must be in [0, 1)");
  require(coherence_corner_hz > 0.0, "coherence_corner_hz", "must be > 0 Hz (infinite: the same share at every frequency)");
  require(rotation_deg.allFinite(), "rotation_deg", "must be finite");
  require(gain.allFinite() && (gain.array() != 0.0).all(), "gain", "must be finite and non-zero");
  require(std::isfinite(z_from_x), "z_from_x", "must be finite");
  require(white_nT >= 0.0 && std::isfinite(white_nT), "white_nT", "must be >= 0 nT");
  require(pink_nT_per_sqrt_hz >= 0.0 && std::isfinite(pink_nT_per_sqrt_hz), "pink_nT_per_sqrt_hz", "must be >= 0");
  require(std::isfinite(time_offset_s), "time_offset_s", "must be finite");
  require(gap_count >= 0, "gap_count", "must be >= 0");
  require(gap_length_s > 0.0 && std::isfinite(gap_length_s), "gap_length_s", "must be positive");
}

Eigen::Matrix3d remote_mixing(const RemoteObservatorySettings& settings) {
  // Rows are samples: C = F Q, so column k of Q is the remote's axis k in the pair's frame.
  Eigen::Matrix3d q = rotation_from_vector_deg(settings.rotation_deg) * settings.gain.asDiagonal();
  q(0, 2) += settings.z_from_x;
  return q;
}

VectorRecord simulate_remote_observatory(const SimulationSettings& local, const SimulatedPair& pair,
                                         const RemoteObservatorySettings& settings) {
  settings.validate();
  const std::size_t n = local.samples();
  if (pair.field_nT.rows() != static_cast<Eigen::Index>(n)) {
    throw InputError("keep_clean_field", "the pair must keep its clean field for a remote observatory");
  }
  // Main field and daily variation alone, and an independent realisation of the variations.
  SimulationSettings quiet = clean_field_settings(local);
  quiet.variation_rms_nT = 0.0;
  const Readings main_and_daily = simulate_pair(quiet).field_nT;
  SimulationSettings other = clean_field_settings(local);
  other.seed = local.seed ^ (0x9e3779b97f4a7c15ULL + settings.seed);
  const Readings own = simulate_pair(other).field_nT - main_and_daily;
  const Readings shared = pair.field_nT - main_and_daily;
  const Eigen::Vector3d f(settings.incoherent_fraction, settings.incoherent_fraction, settings.z_incoherent_fraction);
  const Readings field =
      std::isinf(settings.coherence_corner_hz)
          ? Readings(main_and_daily + shared * (1.0 - f.array()).sqrt().matrix().asDiagonal() +
                     own * f.array().sqrt().matrix().asDiagonal())
          : Readings(main_and_daily + mix_by_frequency(shared, own, f, settings.coherence_corner_hz, local.sample_period_s));

  VectorRecord out;
  out.values_nT = field * remote_mixing(settings);
  SimulationRng rng(settings.seed, 41);
  if (settings.pink_nT_per_sqrt_hz > 0.0 && n >= 4) {
    SpectralSynthesizer synth(n);
    const double psd = settings.pink_nT_per_sqrt_hz * settings.pink_nT_per_sqrt_hz;
    for (int c = 0; c < 3; ++c) {
      const Eigen::VectorXcd spectrum = power_law_spectrum(n, local.sample_period_s, 1.0, 0.0, psd, rng);
      out.values_nT.col(c) += synth.synthesize(spectrum, local.sample_period_s) / static_cast<double>(n);
    }
  }
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) out.values_nT(static_cast<Eigen::Index>(i), c) += settings.white_nT * rng.normal();
  const auto gap = static_cast<std::size_t>(std::max(1.0, std::round(settings.gap_length_s / local.sample_period_s)));
  for (int g = 0; g < settings.gap_count && n > gap; ++g) {
    const std::size_t first = static_cast<std::size_t>(rng.uniform_index(n - gap));
    out.values_nT.middleRows(static_cast<Eigen::Index>(first), static_cast<Eigen::Index>(gap)).setConstant(NAN);
  }
  out.time_s.resize(n);
  for (std::size_t i = 0; i < n; ++i) out.time_s[i] = pair.reference.time_s[i] + settings.time_offset_s;
  out.components = {"X", "Y", "Z"};
  out.source = "simulated remote observatory";
  out.station = "RMT";
  return out;
}

}  // namespace magnetometer_insitu_calibration
