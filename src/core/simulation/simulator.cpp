// Simulator of a reference and a test magnetometer with known truth: see simulator.hpp.
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include "magnetometer_insitu_calibration/estimation/calibration_matrix.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/simulation/power_law_noise.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include <algorithm>
#include <climits>
#include <cmath>
#include <limits>
#include <sstream>

namespace magnetometer_insitu_calibration {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;
constexpr double kSecondsPerDay = 86400.0;
constexpr std::size_t kMinSamples = 16;

// Independent random streams of one seed.
enum Stream : std::uint64_t {
  kStreamVariations = 1,
  kStreamReferenceNoise = 2,
  kStreamTestNoise = 3,
  kStreamGaps = 4,
  kStreamSpikes = 5,
};

// Fixed phases (radians) of the 24 h, 12 h, 8 h harmonics of the daily variation, per reference
// component: arbitrary but fixed, so that the daily variation is a function of UTC time of day.
constexpr double kDailyPhase[3][3] = {{0.0, 0.6, 1.2}, {1.9, 2.4, 0.3}, {3.4, 0.9, 2.0}};
struct DailyTrig {
  double cos_phase[3][3], sin_phase[3][3];
  DailyTrig() {
    for (int c = 0; c < 3; ++c)
      for (int h = 0; h < 3; ++h) {
        cos_phase[c][h] = std::cos(kDailyPhase[c][h]);
        sin_phase[c][h] = std::sin(kDailyPhase[c][h]);
      }
  }
};
const DailyTrig kDailyTrig;


template <typename Value>
std::string text_of(const Value& value) {
  std::ostringstream out;
  out.precision(17);
  out << value;
  return out.str();
}

std::string text_of(const Eigen::Vector3d& v) {
  std::ostringstream out;
  out.precision(17);
  out << v(0) << ", " << v(1) << ", " << v(2);
  return out.str();
}

void require(bool condition, const char* field, const std::string& problem) {
  if (!condition) throw InputError(field, problem);
}

Eigen::Matrix3d correlation_matrix(const Eigen::Vector3d& c) {
  Eigen::Matrix3d m;
  m << 1.0, c(0), c(1),  //
      c(0), 1.0, c(2),   //
      c(1), c(2), 1.0;
  return m;
}

std::size_t gap_samples(const SimulationSettings& s) {
  return static_cast<std::size_t>(std::max<long long>(1, std::llround(s.gap_length_s / s.sample_period_s)));
}

std::size_t spike_count(const SimulationSettings& s) {
  return static_cast<std::size_t>(std::llround(s.spikes_per_day * s.duration_s / kSecondsPerDay));
}

// Daily variation at seconds of the UTC day tau (any real; periodic), nT, reference frame:
// sum over h = 1, 2, 3 of A_c w_h cos(h theta - phi_ch), theta = 2 pi tau / 86400. One sincos
// per call; the 12 h and 8 h terms by the double- and triple-angle identities.
Eigen::RowVector3d daily_variation(const SimulationSettings& s, double tau) {
  double cycles = tau / kSecondsPerDay;
  cycles -= std::floor(cycles);  // [0, 1): keeps the argument small
  const double theta = 2.0 * kPi * cycles;
  const double c1 = std::cos(theta), s1 = std::sin(theta);
  const double c2 = c1 * c1 - s1 * s1, s2 = 2.0 * s1 * c1;
  const double c3 = c1 * c2 - s1 * s2, s3 = s1 * c2 + c1 * s2;
  const double ch[3] = {c1, c2, c3}, sh[3] = {s1, s2, s3};
  Eigen::RowVector3d value = Eigen::RowVector3d::Zero();
  for (int h = 0; h < 3; ++h) {
    const double weight = s.daily_harmonic_weights[static_cast<std::size_t>(h)];
    for (int c = 0; c < 3; ++c) {
      // cos(h theta - phi) = cos(h theta) cos(phi) + sin(h theta) sin(phi)
      value(c) += s.daily_amplitude_nT(c) * weight *
                  (ch[h] * kDailyTrig.cos_phase[c][h] + sh[h] * kDailyTrig.sin_phase[c][h]);
    }
  }
  return value;
}

SimulatedInstrument resolve(SimulatedInstrument requested, SimulationRng& rng) {
  if (requested != SimulatedInstrument::kEither) return requested;
  return rng.uniform() < 0.5 ? SimulatedInstrument::kReference : SimulatedInstrument::kTest;
}

bool hits_reference(SimulatedInstrument i) {
  return i == SimulatedInstrument::kReference || i == SimulatedInstrument::kBoth;
}
bool hits_test(SimulatedInstrument i) {
  return i == SimulatedInstrument::kTest || i == SimulatedInstrument::kBoth;
}

/// The clean field, reference frame, nT: B(t_i) and B(t_i - delay).
struct CleanField {
  Readings field;
  Readings field_delayed;
};

/// Adds the correlated power-law variations to the clean field: whitened (sample covariance ->
/// identity), then given diag(rms) C diag(rms) exactly.
void add_variations(const SimulationSettings& s, SpectralSynthesizer& synthesizer, CleanField& clean) {
  const std::size_t n = static_cast<std::size_t>(clean.field.rows());
  const Eigen::Index rows = clean.field.rows();
  const double dt = s.sample_period_s;
  SimulationRng rng(s.field_seed != 0 ? s.field_seed : s.seed, kStreamVariations);
  Readings w(rows, 3), w_delayed(rows, 3);
  for (int c = 0; c < 3; ++c) {
    const Eigen::VectorXcd spectrum =
        power_law_spectrum(n, dt, s.spectral_index, s.variation_corner_hz, 1.0, rng);
    w.col(c) = synthesizer.synthesize(spectrum, dt);
    w_delayed.col(c) = s.delay_s != 0.0 ? synthesizer.synthesize(spectrum, dt, s.delay_s)
                                        : Eigen::VectorXd(w.col(c));
  }
  // x = w M with M = Ls^-T Lc^T D (S = w^T w / N = Ls Ls^T, C = Lc Lc^T).
  const Eigen::Matrix3d sample_cov = (w.transpose() * w) / static_cast<double>(n);
  Eigen::LLT<Eigen::Matrix3d> sample_llt(sample_cov);
  Eigen::Matrix3d whitening = Eigen::Matrix3d::Identity();
  if (sample_llt.info() == Eigen::Success) {
    whitening = sample_llt.matrixU().solve(Eigen::Matrix3d::Identity());  // Ls^-T
  }
  const Eigen::Matrix3d lc = correlation_matrix(s.variation_correlation).llt().matrixL();
  const Eigen::Vector3d rms(s.variation_rms_nT, s.variation_rms_nT,
                            s.variation_rms_nT * s.variation_z_ratio);
  const Eigen::Matrix3d mixing = whitening * lc.transpose() * rms.asDiagonal();
  clean.field += w * mixing;
  clean.field_delayed += w_delayed * mixing;
}

/// The clean field of n samples: main field, variations, daily variation.
CleanField clean_field(const SimulationSettings& s, std::size_t n, SpectralSynthesizer& synthesizer) {
  const Eigen::Index rows = static_cast<Eigen::Index>(n);
  const double dt = s.sample_period_s;
  CleanField clean;
  clean.field.resize(rows, 3);
  clean.field_delayed.resize(rows, 3);
  for (int c = 0; c < 3; ++c) {
    clean.field.col(c).setConstant(s.main_field_nT(c));
  }
  clean.field_delayed = clean.field;
  if (s.variation_rms_nT > 0.0) add_variations(s, synthesizer, clean);
  if (!s.daily_amplitude_nT.isZero()) {
    const double day_start = std::fmod(s.start_time_s, kSecondsPerDay);  // s of the UTC day
    for (std::size_t i = 0; i < n; ++i) {
      const double tau = day_start + static_cast<double>(i) * dt;
      const Eigen::Index r = static_cast<Eigen::Index>(i);
      clean.field.row(r) += daily_variation(s, tau);
      clean.field_delayed.row(r) += daily_variation(s, tau - s.delay_s);
    }
  }
  return clean;
}

/// The test readings without noise, test frame, nT: the delayed field through n_true (tilting
/// about pair.tilt_rate_rad_per_s when set; then pair.tilt_trend_nT_per_day is filled), plus
/// offset and drift.
Readings test_readings(const SimulationSettings& s, const CleanField& clean, const std::vector<double>& time_s,
                       SimulatedPair& pair) {
  const std::size_t n = time_s.size();
  const double dt = s.sample_period_s;
  Readings test(static_cast<Eigen::Index>(n), 3);
  if (s.tilt_rate_deg_per_day == 0.0) {
    test.noalias() = clean.field_delayed * pair.n_true;
  } else {
    const Eigen::Vector3d axis = pair.tilt_rate_rad_per_s.normalized();
    const double rate = pair.tilt_rate_rad_per_s.norm();  // rad/s
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Index r = static_cast<Eigen::Index>(i);
      const Eigen::Matrix3d rotation =
          Eigen::AngleAxisd(rate * (time_s[i] - pair.tilt_reference_time_s), axis).toRotationMatrix();
      test.row(r) = clean.field_delayed.row(r) * rotation * pair.n_true;
    }
    const Eigen::RowVector3d mean_field = clean.field.colwise().mean();
    Eigen::Matrix3d cross;  // [w]x, w in rad/day
    const Eigen::Vector3d w_day = pair.tilt_rate_rad_per_s * kSecondsPerDay;
    cross << 0.0, -w_day(2), w_day(1),  //
        w_day(2), 0.0, -w_day(0),       //
        -w_day(1), w_day(0), 0.0;
    pair.tilt_trend_nT_per_day = (mean_field * cross * pair.n_true).transpose();
  }
  for (std::size_t i = 0; i < n; ++i) {
    const double days = static_cast<double>(i) * dt / kSecondsPerDay;
    test.row(static_cast<Eigen::Index>(i)) +=
        (s.test_offset_nT + s.drift_nT_per_day * days).transpose();
  }
  return test;
}

/// Gaps: gap_count runs of L samples, separated by >= 1 sample, set to NaN in the instruments
/// they hit and listed in pair.gaps. Returns, per sample, whether it lies in a gap.
std::vector<char> add_gaps(const SimulationSettings& s, Readings& reference, Readings& test, SimulatedPair& pair) {
  const std::size_t n = static_cast<std::size_t>(reference.rows());
  std::vector<char> in_gap(n, 0);
  if (s.gap_count <= 0) return in_gap;
  SimulationRng rng(s.seed, kStreamGaps);
  const std::size_t length = gap_samples(s);
  const std::size_t count = static_cast<std::size_t>(s.gap_count);
  const std::size_t free = n - count * (length + 1);
  std::vector<std::size_t> offsets(count);
  for (auto& o : offsets) o = static_cast<std::size_t>(rng.uniform_index(free + 1));
  std::sort(offsets.begin(), offsets.end());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t g = 0; g < count; ++g) {
    SimulatedGap gap;
    gap.first_index = offsets[g] + g * (length + 1);
    gap.length = length;
    gap.instrument = resolve(s.gap_instrument, rng);
    const Eigen::Index first = static_cast<Eigen::Index>(gap.first_index);
    const Eigen::Index len = static_cast<Eigen::Index>(length);
    if (hits_reference(gap.instrument)) reference.middleRows(first, len).setConstant(nan);
    if (hits_test(gap.instrument)) test.middleRows(first, len).setConstant(nan);
    std::fill(in_gap.begin() + static_cast<std::ptrdiff_t>(gap.first_index),
              in_gap.begin() + static_cast<std::ptrdiff_t>(gap.first_index + length), 1);
    pair.gaps.push_back(gap);
  }
  return in_gap;
}

/// Spikes: distinct samples outside every gap, +-spike_amplitude_nT on one component of the
/// instruments they hit; listed in pair.spikes in sample order.
void add_spikes(const SimulationSettings& s, const std::vector<char>& in_gap, Readings& reference, Readings& test,
                SimulatedPair& pair) {
  const std::size_t n = in_gap.size();
  const std::size_t spikes = spike_count(s);
  if (spikes == 0) return;
  SimulationRng rng(s.seed, kStreamSpikes);
  std::vector<char> taken = in_gap;
  for (std::size_t k = 0; k < spikes; ++k) {
    std::size_t index;
    do {
      index = static_cast<std::size_t>(rng.uniform_index(n));
    } while (taken[index]);
    taken[index] = 1;
    SimulatedSpike spike;
    spike.index = index;
    spike.instrument = resolve(s.spike_instrument, rng);
    spike.component = static_cast<int>(rng.uniform_index(3));
    spike.amplitude_nT = rng.uniform() < 0.5 ? -s.spike_amplitude_nT : s.spike_amplitude_nT;
    const Eigen::Index r = static_cast<Eigen::Index>(index);
    if (hits_reference(spike.instrument)) reference(r, spike.component) += spike.amplitude_nT;
    if (hits_test(spike.instrument)) test(r, spike.component) += spike.amplitude_nT;
    pair.spikes.push_back(spike);
  }
  std::sort(pair.spikes.begin(), pair.spikes.end(),
            [](const SimulatedSpike& a, const SimulatedSpike& b) { return a.index < b.index; });
}

}  // namespace

const char* simulated_instrument_name(SimulatedInstrument instrument) {
  switch (instrument) {
    case SimulatedInstrument::kReference: return "reference";
    case SimulatedInstrument::kTest: return "test";
    case SimulatedInstrument::kEither: return "either";
    case SimulatedInstrument::kBoth: return "both";
  }
  return "unknown";
}

SimulatedInstrument parse_simulated_instrument(const std::string& text, const std::string& where) {
  if (text == "reference") return SimulatedInstrument::kReference;
  if (text == "test") return SimulatedInstrument::kTest;
  if (text == "either") return SimulatedInstrument::kEither;
  if (text == "both") return SimulatedInstrument::kBoth;
  throw InputError(where, "expected reference, test, either or both, got '" + text + "'");
}

std::size_t SimulationSettings::samples() const {
  if (!(sample_period_s > 0.0) || !std::isfinite(duration_s / sample_period_s)) return 0;
  const double count = std::round(duration_s / sample_period_s);
  if (count < 0.0 || count > static_cast<double>(INT_MAX)) return 0;
  return static_cast<std::size_t>(count);
}

Eigen::Matrix3d SimulationSettings::n_true() const {
  if (n_explicit) return *n_explicit;
  return matrix_from_angles(scale_ratio, nonorthogonality_deg, misalignment_deg);
}

void SimulationSettings::validate() const {
  require(std::isfinite(start_time_s), "start_time_s", "must be finite");
  require(sample_period_s > 0.0 && std::isfinite(sample_period_s), "sample_period_s",
          "must be positive, got " + text_of(sample_period_s));
  require(duration_s > 0.0 && std::isfinite(duration_s), "duration_s",
          "must be positive, got " + text_of(duration_s));
  const std::size_t n = samples();
  require(n >= kMinSamples, "duration_s",
          "gives " + std::to_string(n) + " samples; need " + std::to_string(kMinSamples) +
              " to " + std::to_string(INT_MAX));

  require(main_field_nT.allFinite(), "main_field_nT", "must be finite");
  require(std::isfinite(spectral_index), "spectral_index", "must be finite");
  require(variation_corner_hz >= 0.0 && std::isfinite(variation_corner_hz), "variation_corner_hz",
          "must be >= 0, got " + text_of(variation_corner_hz));
  require(variation_rms_nT >= 0.0 && std::isfinite(variation_rms_nT), "variation_rms_nT",
          "must be >= 0, got " + text_of(variation_rms_nT));
  require(variation_z_ratio >= 0.0 && std::isfinite(variation_z_ratio), "variation_z_ratio",
          "must be >= 0, got " + text_of(variation_z_ratio));
  require(variation_correlation.allFinite() && (variation_correlation.array().abs() < 1.0).all(),
          "variation_correlation", "each coefficient must lie in (-1, 1), got " +
                                       text_of(variation_correlation));
  {
    Eigen::LLT<Eigen::Matrix3d> llt(correlation_matrix(variation_correlation));
    require(llt.info() == Eigen::Success, "variation_correlation",
            "coefficients " + text_of(variation_correlation) + " are not a valid correlation matrix");
  }
  require(daily_amplitude_nT.allFinite(), "daily_amplitude_nT", "must be finite");
  require(std::all_of(daily_harmonic_weights.begin(), daily_harmonic_weights.end(),
                      [](double w) { return std::isfinite(w); }),
          "daily_harmonic_weights", "must be finite");

  if (n_explicit) {
    require(n_explicit->allFinite(), "n_explicit", "must be finite");
    require(std::abs(n_explicit->determinant()) > 1e-9, "n_explicit", "must be non-singular");
  } else {
    (void)matrix_from_angles(scale_ratio, nonorthogonality_deg, misalignment_deg);  // throws
  }

  require(reference_white_nT >= 0.0 && std::isfinite(reference_white_nT), "reference_white_nT",
          "must be >= 0, got " + text_of(reference_white_nT));
  require(test_white_nT >= 0.0 && std::isfinite(test_white_nT), "test_white_nT",
          "must be >= 0, got " + text_of(test_white_nT));
  require(reference_pink_nT_per_sqrt_hz >= 0.0 && std::isfinite(reference_pink_nT_per_sqrt_hz),
          "reference_pink_nT_per_sqrt_hz", "must be >= 0");
  require(test_pink_nT_per_sqrt_hz >= 0.0 && std::isfinite(test_pink_nT_per_sqrt_hz),
          "test_pink_nT_per_sqrt_hz", "must be >= 0");

  require(test_offset_nT.allFinite(), "test_offset_nT", "must be finite");
  require(drift_nT_per_day.allFinite(), "drift_nT_per_day", "must be finite");
  require(std::isfinite(tilt_rate_deg_per_day), "tilt_rate_deg_per_day", "must be finite");
  require(tilt_axis.allFinite() && (tilt_rate_deg_per_day == 0.0 || tilt_axis.norm() > 0.0),
          "tilt_axis", "must be finite and non-zero");
  require(std::isfinite(delay_s) && std::abs(delay_s) < duration_s, "delay_s",
          "must be finite and shorter than the record, got " + text_of(delay_s));

  require(spikes_per_day >= 0.0 && std::isfinite(spikes_per_day), "spikes_per_day",
          "must be >= 0, got " + text_of(spikes_per_day));
  require(std::isfinite(spike_amplitude_nT), "spike_amplitude_nT", "must be finite");
  require(gap_count >= 0, "gap_count", "must be >= 0, got " + std::to_string(gap_count));
  require(gap_length_s > 0.0 && std::isfinite(gap_length_s), "gap_length_s",
          "must be positive, got " + text_of(gap_length_s));
  const std::size_t gap_total = static_cast<std::size_t>(gap_count) * (gap_samples(*this) + 1);
  require(gap_total <= n, "gap_count",
          std::to_string(gap_count) + " gaps of " + std::to_string(gap_samples(*this)) +
              " samples do not fit in " + std::to_string(n) + " samples");
  require(2 * spike_count(*this) <= n - gap_total, "spikes_per_day",
          std::to_string(spike_count(*this)) + " spikes do not fit in the " +
              std::to_string(n - gap_total) + " samples outside gaps (at most half of them)");
}

Eigen::Matrix3d SimulatedPair::n_at(double time_s) const {
  const Eigen::Vector3d angle = tilt_rate_rad_per_s * (time_s - tilt_reference_time_s);
  const double theta = angle.norm();
  if (theta == 0.0) return n_true;
  return Eigen::AngleAxisd(theta, angle / theta).toRotationMatrix() * n_true;
}

SimulatedPair simulate_pair(const SimulationSettings& s) {
  s.validate();
  const std::size_t n = s.samples();
  const double dt = s.sample_period_s;

  SimulatedPair pair;
  pair.n_true = s.n_true();
  pair.trend_nT_per_day = s.drift_nT_per_day;
  pair.tilt_reference_time_s = s.start_time_s + 0.5 * static_cast<double>(n - 1) * dt;
  if (s.tilt_rate_deg_per_day != 0.0) {
    pair.tilt_rate_rad_per_s =
        s.tilt_axis.normalized() * (s.tilt_rate_deg_per_day * kDegToRad / kSecondsPerDay);
  }

  std::vector<double> time_s(n);
  for (std::size_t i = 0; i < n; ++i) time_s[i] = s.start_time_s + static_cast<double>(i) * dt;

  SpectralSynthesizer synthesizer(n);
  CleanField clean = clean_field(s, n, synthesizer);

  Readings reference = clean.field;
  Readings test = test_readings(s, clean, time_s, pair);
  {
    SimulationRng rng(s.seed, kStreamReferenceNoise);
    add_instrument_noise(reference, s.reference_white_nT, s.reference_pink_nT_per_sqrt_hz, dt, rng, synthesizer);
  }
  {
    SimulationRng rng(s.seed, kStreamTestNoise);
    add_instrument_noise(test, s.test_white_nT, s.test_pink_nT_per_sqrt_hz, dt, rng, synthesizer);
  }
  const std::vector<char> in_gap = add_gaps(s, reference, test, pair);
  add_spikes(s, in_gap, reference, test, pair);

  // --- Records ---------------------------------------------------------------------------------
  pair.reference.time_s = time_s;
  pair.reference.values_nT = std::move(reference);
  pair.reference.source = "simulated reference (seed " + std::to_string(s.seed) + ")";
  pair.reference.station = "SIM";
  pair.test.time_s = std::move(time_s);
  pair.test.values_nT = std::move(test);
  pair.test.source = "simulated test (seed " + std::to_string(s.seed) + ")";
  pair.test.station = "SIM";
  if (s.keep_clean_field) {
    pair.field_nT = std::move(clean.field);
    pair.field_delayed_nT = std::move(clean.field_delayed);
  }
  return pair;
}

}  // namespace magnetometer_insitu_calibration
