// Held-out real check of the reference noise that the default identifies from the pair above the
// band, by an absolute scalar magnetometer recording beside the pair (docs/validation.md, "The
// reference's noise against an absolute scalar magnetometer").
//
// The pair identifies the reference's noise above the band, 0.03-0.25 Hz at 1 s, where the test's
// response is not known, and extrapolates it into the band by a white + 1/f fit. A scalar
// instrument (proton, Overhauser or optically pumped: at every INTERMAGNET observatory) records
// F, whose variations are p . B for the unit vector p of the main field. With the reference R,
// the test mapped into the reference's frame, G = T n^-1, and F, the cross-spectral
// three-cornered hat on the three series R p, G p and F gives each one's own noise along p:
//   N_R(p) = S_RR - Re(S_RF S_GR / S_GF)     (S_uv: bin means of U V^*, one-sided, nT^2/Hz)
// Any gain, delay or filter of the test or of the scalar cancels in the ratio, and F's own noise
// does not enter N_R's mean. So N_R along p is measured in and above the band, independently of
// the pair's model and of the test's response. p is where the scalar sees the field: the in-band
// Eq. 2 fit of F on the reference (F = R c + trend), normalised; |c| is the reference's gain along
// the field against the absolute instrument (1 when both are right).
//
//   scalar_instrument_check REF TEST SCALAR [REF TEST SCALAR ...]
//
// REF and TEST in any format `calibrate_records` reads; SCALAR a MagPy CDF file holding `f` (nT)
// on its DEPEND_0 time variable (else Epoch), interpolated linearly onto the pair's epochs (a
// scalar magnetometer's stamps are often not on whole seconds). A program, not a test: the
// scalar record of the second day is not shipped (docs/validation.md, "Real WIC days", says where
// the records come from).
#include <fftw3.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <exception>
#include <stdexcept>
#include <string>
#include <vector>

#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/formats/cdf_epoch.hpp"
#include "magnetometer_insitu_calibration/formats/cdf_file.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/pipeline/reference_noise.hpp"
#include "magnetometer_insitu_calibration/pipeline/temperature_channel.hpp"
#include "magnetometer_insitu_calibration/preprocessing/gap_filling.hpp"
#include "window_agreement.hpp"

namespace mic = magnetometer_insitu_calibration;
using cd = std::complex<double>;

namespace {

constexpr double kPi = 3.14159265358979323846;

/// The scalar record's F (nT) at the given UNIX epochs, linear between its own samples
/// (interpolate_channel, as the temperature channel); NaN where its neighbours are more than 2 s
/// apart or outside the record.
Eigen::VectorXd scalar_on_epochs(const std::string& path, const std::vector<double>& epochs_s) {
  const mic::CdfFile file = mic::CdfFile::open(path);
  const mic::CdfVariable* f = file.find("f");
  if (!f) throw std::runtime_error(path + ": no variable 'f' (a MagPy CDF scalar record)");
  std::string time_name = "Epoch";
  for (const auto& a : f->attributes)
    if (a.first == "DEPEND_0" && !a.second.text.empty()) time_name = a.second.text;
  const mic::CdfVariable* t = file.find(time_name);
  if (!t || t->data_type != mic::kCdfTimeTt2000)
    throw std::runtime_error(path + ": no TT2000 time variable " + time_name);
  const std::vector<std::int64_t> tt = file.read_int64(*t);
  std::vector<double> values = file.read_real(*f), time_s;
  for (std::size_t i = 0; i < tt.size(); ++i) {
    double unix_s = 0.0;
    if (mic::tt2000_to_unix(tt[i], unix_s) != mic::Tt2000Status::kOk) continue;
    time_s.push_back(unix_s);
    values[time_s.size() - 1] = values[i];
  }
  values.resize(time_s.size());
  return mic::interpolate_channel(time_s, values, epochs_s, 2.0);
}

/// Hann-windowed DFT of x less its straight line, scaled so that 2 dt |X_j|^2
/// is the one-sided PSD (nT^2/Hz). Bins 0 .. N/2.
std::vector<cd> spectrum(const Eigen::VectorXd& x, double dt) {
  const long n = x.size();
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(n, -1.0, 1.0);
  const double slope = t.dot(x) / t.squaredNorm(), mean = x.mean();
  std::vector<double> in(n);
  double w2 = 0.0;
  for (long i = 0; i < n; ++i) {
    const double w = 0.5 - 0.5 * std::cos(2.0 * kPi * static_cast<double>(i) / static_cast<double>(n));
    in[i] = (x(i) - mean - slope * t(i)) * w;
    w2 += w * w;
  }
  std::vector<cd> out(n / 2 + 1);
  fftw_plan plan;
  {
    std::lock_guard<std::mutex> lock(mic::fftw_planner_lock());
    plan = fftw_plan_dft_r2c_1d(static_cast<int>(n), in.data(), reinterpret_cast<fftw_complex*>(out.data()),
                                FFTW_ESTIMATE);
  }
  fftw_execute(plan);
  {
    std::lock_guard<std::mutex> lock(mic::fftw_planner_lock());
    fftw_destroy_plan(plan);
  }
  const double scale = std::sqrt(dt / w2);
  for (cd& v : out) v *= scale;
  return out;
}

struct HatBin {
  double low_hz, high_hz;
  long harmonics;
  double noise[3], sd[3];  ///< reference, test, scalar: one-sided PSD along p, nT^2/Hz
};

/// The cross-spectral hat on three scalar series over [low, high) Hz; each
/// noise's standard deviation by a delete-one-block jackknife over 10
/// contiguous blocks of the bin's harmonics. (Interleaved groups, every 10th
/// harmonic, gave 0.57-0.87 of the scatter of 40 simulated days: the Hann window
/// ties neighbouring harmonics; contiguous blocks gave 0.99-1.13 of it.)
HatBin hat_bin(const std::vector<cd>& r, const std::vector<cd>& g, const std::vector<cd>& f, double df, double low,
               double high) {
  const long j0 = static_cast<long>(std::ceil(low / df)), j1 = static_cast<long>(std::ceil(high / df));
  constexpr int kGroups = 10;
  auto estimate = [&](int skip, double out[3]) {
    cd srr = 0, sgg = 0, sff = 0, srf = 0, sgr = 0, sgf = 0;
    long used = 0;
    for (long j = j0; j < j1; ++j) {
      if (skip >= 0 && (j - j0) * kGroups / (j1 - j0) == skip) continue;
      ++used;
      srr += std::norm(r[j]), sgg += std::norm(g[j]), sff += std::norm(f[j]);
      srf += r[j] * std::conj(f[j]), sgr += g[j] * std::conj(r[j]), sgf += g[j] * std::conj(f[j]);
    }
    // Each series' noise is its power less the field's part, |H|^2 S for its transfer H, from the
    // cross-spectra with the other two (S_uv = sum U V^*; S_vu = conj(S_uv)).
    out[0] = (srr - srf * sgr / sgf).real();                        // S_RF S_GR / S_GF
    out[1] = (sgg - sgr * std::conj(sgf) / std::conj(srf)).real();  // S_GR S_FG / S_FR
    out[2] = (sff - std::conj(srf) * sgf / sgr).real();             // S_FR S_GF / S_GR
    for (int k = 0; k < 3; ++k) out[k] *= 2.0 / static_cast<double>(used);
  };
  HatBin bin{low, high, j1 - j0, {}, {}};
  estimate(-1, bin.noise);
  double leave[kGroups][3], mean[3] = {0, 0, 0};
  for (int g_ = 0; g_ < kGroups; ++g_) {
    estimate(g_, leave[g_]);
    for (int k = 0; k < 3; ++k) mean[k] += leave[g_][k] / kGroups;
  }
  for (int k = 0; k < 3; ++k) {
    double ss = 0.0;
    for (int g_ = 0; g_ < kGroups; ++g_) ss += (leave[g_][k] - mean[k]) * (leave[g_][k] - mean[k]);
    bin.sd[k] = std::sqrt(ss * (kGroups - 1) / kGroups);
  }
  return bin;
}

/// A PSD as an amplitude spectral density, pT/sqrt(Hz), keeping its sign.
double asd_pT(double psd) { return (psd < 0 ? -1.0 : 1.0) * 1000.0 * std::sqrt(std::fabs(psd)); }

/// What the scalar's levels would do to n: the hat's noise along p fitted white
/// + 1/f over all its bins (in and above the band), the part the pair's model
/// does not give along p put on z (81 % of p at WIC; the vertical is the weak
/// axis), and the day and its quarters estimated again by the default with
/// those levels given as the reference's noise figure (their own uncertainty
/// not propagated).
void what_if(const mic::PreparedPair& prepared, const std::vector<mic::CalibrationWindow>& default_windows,
             mic::CalibrationSettings settings, const mic::IdentifiedNoise& pair, const Eigen::Vector3d& p,
             const std::vector<Eigen::Vector3d>& along_p, const std::vector<Eigen::Vector3d>& along_p_sd,
             const std::vector<double>& lows, const std::vector<double>& highs) {
  const double dt = prepared.sample_period_s;
  Eigen::Vector3d white, pink;
  if (!mic::fit_white_and_pink(along_p, along_p_sd, lows, highs, dt, white, pink, nullptr)) {
    std::printf("  no positive level along p\n");
    return;
  }
  Eigen::Vector3d z_white = pair.white_nT, z_pink = pair.pink_nT_per_sqrt_hz;
  auto z_level = [&](double along, const Eigen::Vector3d& levels) {
    const double rest = p(0) * p(0) * levels(0) * levels(0) + p(1) * p(1) * levels(1) * levels(1);
    return std::sqrt(std::max(0.0, along * along - rest) / (p(2) * p(2)));
  };
  z_white(2) = z_level(white(0), pair.white_nT);
  z_pink(2) = z_level(pink(0), pair.pink_nT_per_sqrt_hz);
  std::printf(
      "  along p, fitted: white %.1f pT rms, 1/f %.2f pT/sqrt(Hz) at 1 Hz; given on z: %.1f pT rms, %.2f pT/sqrt(Hz)\n",
      1000 * white(0), 1000 * pink(0), 1000 * z_white(2), 1000 * z_pink(2));
  mic::CalibrationSettings given = settings;
  given.window.reference_noise_figure.white_nT = z_white;
  given.window.reference_noise_figure.pink_nT_per_sqrt_hz = z_pink;
  given.window.pair_noise = false;
  const std::vector<mic::CalibrationWindow> given_windows = mic::calibrate_prepared(prepared, given);
  for (const auto& run :
       {std::make_pair("default", &default_windows), std::make_pair("scalar's z level", &given_windows)}) {
    const std::vector<mic::CalibrationWindow>& windows = *run.second;
    std::vector<monte_carlo::SixParameters> quarters;
    for (std::size_t w = 0; w + 1 < windows.size(); ++w) quarters.push_back(monte_carlo::six_parameters(windows[w]));
    const monte_carlo::SixParameters day = monte_carlo::six_parameters(windows.back());
    std::printf("  %-17s scale z %.5f +- %.5f; quarters' z", run.first, day.value[2], day.ci95(2));
    for (const auto& q : quarters) std::printf(" %.5f", q.value[2]);
    const std::array<double, 6> scatter = monte_carlo::quarters_scatter(windows);
    std::printf("; sqrt(chi2/3) %.2f %.2f %.2f; %.2f %.2f %.2f\n", scatter[0], scatter[1], scatter[2], scatter[3],
                scatter[4], scatter[5]);
  }
}

void check_day(const std::string& ref_path, const std::string& test_path, const std::string& scalar_path) {
  const mic::VectorRecord ref_record = mic::read_record(ref_path), test_record = mic::read_record(test_path);
  mic::CalibrationSettings settings;  // the package's default, four quarters and the day
  settings.windows.intervals = 4;
  const mic::PreparedPair prepared = mic::prepare_pair(ref_record, test_record, settings.preprocess);
  const double dt = prepared.sample_period_s;
  const std::vector<mic::CalibrationWindow> windows = mic::calibrate_prepared(prepared, settings);
  const mic::CalibrationWindow& day = windows.back();
  // The whole record with its gaps filled, as the per-window stage fills the day's window.
  mic::PreparedPair filled = prepared;
  mic::fill_gaps(filled.paired, dt, settings.window.gaps);
  const auto& paired = filled.paired;
  mic::CalibrationSettings first_settings = settings;  // the pair's first estimate, as the pipeline makes it
  first_settings.window.pair_noise = false;
  first_settings.windows.intervals = 0;
  const mic::CalibrationWindow first = mic::calibrate_prepared(prepared, first_settings).back();
  const mic::IdentifiedNoise pair =
      mic::identify_reference_noise_from_pair(paired.reference_nT, paired.test_nT, dt, first.estimate,
                                              first.response_model, settings.window.estimator.band_high_hz);

  // The pair's epochs that the scalar record covers (its first stamp may fall after the pair's).
  const Eigen::VectorXd f_all = scalar_on_epochs(scalar_path, paired.time_s);
  long first_i = 0, last_i = f_all.size() - 1;
  while (first_i < f_all.size() && !std::isfinite(f_all(first_i))) ++first_i;
  while (last_i > first_i && !std::isfinite(f_all(last_i))) --last_i;
  const long count = last_i - first_i + 1;
  if (count < 3600) throw std::runtime_error(scalar_path + ": covers fewer than 3600 of the pair's epochs");
  const Eigen::VectorXd scalar = f_all.segment(first_i, count);
  long missing = 0;
  for (long i = 0; i < count; ++i) missing += !std::isfinite(scalar(i));
  if (missing > 0)
    throw std::runtime_error(scalar_path + ": " + std::to_string(missing) + " of the pair's epochs have no F");
  const mic::Readings reference = paired.reference_nT.middleRows(first_i, count);
  const mic::Readings test = paired.test_nT.middleRows(first_i, count);

  // c: Eq. 2 of F (as all three test columns) on the reference, over the default band.
  mic::Readings f3(scalar.size(), 3);
  f3.col(0) = f3.col(1) = f3.col(2) = scalar;
  mic::FdWlseEstimator plain{mic::EstimatorSettings{}};
  const mic::WindowEstimate fit = plain.estimate(reference, f3, dt);
  const Eigen::Vector3d c = fit.n.col(0);
  Eigen::Vector3d c_se;
  for (int i = 0; i < 3; ++i) c_se(i) = std::sqrt(fit.n_covariance(3 * i, 3 * i));
  const Eigen::Vector3d p = c.normalized();

  const Eigen::VectorXd r_p = reference * p;
  const Eigen::VectorXd g_p = test * (day.estimate.n.inverse() * p);
  const std::vector<cd> sr = spectrum(r_p, dt), sg = spectrum(g_p, dt), sf = spectrum(scalar, dt);
  const double df = 1.0 / (static_cast<double>(r_p.size()) * dt);

  std::printf("\n## %s, %ld epochs\n", mic::format_iso8601(paired.time_s[first_i]).substr(0, 10).c_str(), count);
  std::printf("  F on the reference over %.4f-%.3f Hz: c = %.5f %.5f %.5f (se %.5f %.5f %.5f), |c| = %.5f\n",
              settings.window.estimator.band_low_hz, settings.window.estimator.band_high_hz, c(0), c(1), c(2), c_se(0), c_se(1),
              c_se(2), c.norm());
  std::printf("  pair's reference noise (%s)\n", pair.text.c_str());
  std::printf("  %-15s %6s | %-21s %9s %9s | %-17s %-17s\n", "bin, Hz", "harm.", "reference along p", "pair", "maker",
              "test along p", "scalar");
  std::vector<double> edges;
  for (int k = 0; k <= 5; ++k) edges.push_back(0.0002 * std::pow(50.0, k / 5.0));  // the band, 0.0002-0.01 Hz
  for (int k = 1; k <= 6; ++k) edges.push_back(0.01 * std::pow(25.0, k / 6.0));    // above it, to 0.25 Hz
  // The reference's along p, put on every axis: fit_white_and_pink fits per axis.
  std::vector<Eigen::Vector3d> along_p, along_p_sd;
  std::vector<double> lows, highs;
  for (std::size_t b = 0; b + 1 < edges.size(); ++b) {
    const HatBin bin = hat_bin(sr, sg, sf, df, edges[b], edges[b + 1]);
    along_p.push_back(Eigen::Vector3d::Constant(bin.noise[0]));
    along_p_sd.push_back(Eigen::Vector3d::Constant(bin.sd[0]));
    lows.push_back(bin.low_hz);
    highs.push_back(bin.high_hz);
    // The pair's model along p (axes' noises independent), averaged over the bin.
    const double mean_inv_f = std::log(bin.high_hz / bin.low_hz) / (bin.high_hz - bin.low_hz);
    double model = 0.0;
    for (int i = 0; i < 3; ++i)
      model += p(i) * p(i) *
               (2.0 * pair.white_nT(i) * pair.white_nT(i) * dt +
                pair.pink_nT_per_sqrt_hz(i) * pair.pink_nT_per_sqrt_hz(i) * mean_inv_f);
    std::printf("  %.4f-%.4f %6ld | %7.1f (%6.1f-%6.1f) %9.1f %9.1f | %7.1f +- %6.1f %7.1f +- %6.1f\n", bin.low_hz,
                bin.high_hz, bin.harmonics, asd_pT(bin.noise[0]), asd_pT(bin.noise[0] - bin.sd[0]),
                asd_pT(bin.noise[0] + bin.sd[0]), asd_pT(model), 10.0, asd_pT(bin.noise[1]), asd_pT(bin.sd[1]),
                asd_pT(bin.noise[2]), asd_pT(bin.sd[2]));
  }
  what_if(prepared, windows, settings, pair, p, along_p, along_p_sd, lows, highs);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4 || (argc - 1) % 3 != 0) {
    std::fprintf(stderr, "usage: scalar_instrument_check REF TEST SCALAR [REF TEST SCALAR ...]\n");
    return 2;
  }
  try {
    std::printf(
        "# ASD in pT/sqrt(Hz) along p, the field's direction in the reference's frame; the reference's\n"
        "# as the hat's estimate (its estimate -+ one jackknife sd), the pair's white + 1/f model, the\n"
        "# maker's figure (LEMI-036: < 10 pT/sqrt(Hz)); the test's and the scalar's with their sd\n");
    for (int a = 1; a + 2 < argc; a += 3) check_day(argv[a], argv[a + 1], argv[a + 2]);
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "scalar_instrument_check: %s\n", ex.what());
    return 1;
  }
  return 0;
}
