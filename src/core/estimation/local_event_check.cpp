// The local-event check of a window: see local_event_check.hpp.
#include "magnetometer_insitu_calibration/estimation/local_event_check.hpp"

#include "spectral_tools.hpp"  // detail::thread_real_dft, detail::median_in_place

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numeric>
#include <sstream>
#include <vector>

namespace magnetometer_insitu_calibration {

namespace {

using Complex3 = Eigen::Matrix<std::complex<double>, 3, 3>;

constexpr double kLowestEventHz = 0.02;   // events of seconds to a minute or two
constexpr double kBlockPeriods = 2.56;     // block length in periods of f1 (128 s at 0.02 Hz)
constexpr int kMinBlocks = 64;
constexpr int kLocalMedianHalf = 15;       // running median over 31 blocks

using Row = Eigen::Matrix<std::complex<double>, 1, 3>;

/// The spectra of the blocks kept: row (block b, harmonic j of the event band) at
/// b * harmonics + j of reference and test (3 components each).
struct BlockSpectra {
  std::vector<Row> reference, test;
  std::vector<double> frequency_hz;  // of the harmonics kept
  int blocks = 0;                    // kept
  int skipped = 0;                   // blocks with a straight-line fill
};

/// A record as the check reads it: averaged in groups of `step` samples (1 or 2), the values of
/// detail::average_pairs (pair_averages.hpp) read in place, so that they need no copy of the window.
struct SteppedRecord {
  const Eigen::Ref<const Readings>& x;
  int step;
  Eigen::Index size() const { return x.rows() / step; }
  double operator()(Eigen::Index k, int c) const {
    return step == 1 ? x(k, c) : 0.5 * (x(2 * k, c) + x(2 * k + 1, c));
  }
};

/// Whether values [from, to) of every column hold a run of kFillRun values whose second
/// differences are zero to rounding: a straight line the pipeline or the screen filled a gap or
/// a masked run with (in both records alike, so the reference tells). Such a block's energies
/// would be low in R and in E together.
bool has_straight_fill(const SteppedRecord& x, Eigen::Index from, Eigen::Index to) {
  constexpr int kFillRun = 4;
  int run = 0;
  for (Eigen::Index i = std::max<Eigen::Index>(from, 1); i + 1 < std::min(to, x.size()); ++i) {
    bool straight = true;
    for (int c = 0; c < 3 && straight; ++c) {
      const double d2 = x(i + 1, c) - 2.0 * x(i, c) + x(i - 1, c);
      straight = std::abs(d2) <= 1e-9 * (1.0 + std::abs(x(i, c)));
    }
    run = straight ? run + 1 : 0;
    if (run >= kFillRun) return true;
  }
  return false;
}

/// The blocks' spectra. Both records are differenced (each value's change, nT per value: the
/// same linear filter on R and T, which H takes; it lowers the band's strong red field by f^2 so
/// that the taper's sidelobes cannot carry it into the event band, where it follows n, not H);
/// each block less its mean, Hann-tapered and transformed. The test's block starts `shift`
/// values after the reference's (the window's delay to the nearest value), so that the taper
/// weighs the same field in both. Blocks holding a straight-line fill are left out.
BlockSpectra block_spectra(const SteppedRecord& r, const SteppedRecord& t, int length, int shift, int first_harmonic,
                           int last_harmonic, double df) {
  const Eigen::Index n = r.size();
  detail::RealDft& dft = detail::thread_real_dft();  // this thread's plans, kept between windows
  const std::size_t size = static_cast<std::size_t>(length);
  Eigen::Map<Eigen::ArrayXd> buffer(dft.input(size), length);
  Eigen::ArrayXd hann(length);
  Eigen::VectorXcd spectrum;
  for (int i = 0; i < length; ++i) hann(i) = 0.5 - 0.5 * std::cos(2.0 * M_PI * (i + 0.5) / length);
  BlockSpectra out;
  for (int j = first_harmonic; j <= last_harmonic; ++j) out.frequency_hz.push_back(j * df);
  const std::size_t harmonics = out.frequency_hz.size();
  out.reference.resize(static_cast<std::size_t>(n / length + 1) * harmonics);
  out.test.resize(out.reference.size());
  // A block: the changes from value start - 1 + i to start + i, i < length (R), and from
  // start + shift on (T).
  const Eigen::Index lead = 1 + std::max(0, -shift), end = n - std::max(0, shift);
  for (Eigen::Index start = lead; start + length <= end; start += length) {
    if (has_straight_fill(r, std::min(start, start + shift) - 1, std::max(start, start + shift) + length + 1)) {
      ++out.skipped;
      continue;
    }
    for (int which = 0; which < 2; ++which) {
      const SteppedRecord& x = which == 0 ? r : t;
      const Eigen::Index from = which == 0 ? start : start + shift;
      Row* rows = (which == 0 ? out.reference : out.test).data() + static_cast<std::size_t>(out.blocks) * harmonics;
      for (int c = 0; c < 3; ++c) {
        double previous = x(from - 1, c);
        for (int i = 0; i < length; ++i) {
          const double value = x(from + i, c);
          buffer(i) = value - previous;
          previous = value;
        }
        buffer = (buffer - buffer.mean()) * hann;
        dft.execute(size, static_cast<std::size_t>(last_harmonic) + 1, spectrum);
        for (std::size_t j = 0; j < harmonics; ++j) {
          rows[j](c) = spectrum(first_harmonic + static_cast<Eigen::Index>(j));
        }
      }
    }
    ++out.blocks;
  }
  return out;
}

/// log(x) less its running median over 2 kLocalMedianHalf + 1 values, the median taken every
/// kMedianStride values and interpolated between (it follows hours, not blocks).
std::vector<double> local_log(const std::vector<double>& x) {
  constexpr std::size_t kMedianStride = 8;
  const std::size_t n = x.size(), half = kLocalMedianHalf;
  std::vector<double> lx(n), out(n), window;
  for (std::size_t i = 0; i < n; ++i) lx[i] = std::log(std::max(x[i], 1e-300));
  auto median_at = [&](std::size_t i) {
    const std::size_t a = i >= half ? i - half : 0, b = std::min(n, i + half + 1);
    window.assign(lx.begin() + static_cast<std::ptrdiff_t>(a), lx.begin() + static_cast<std::ptrdiff_t>(b));
    return detail::median_in_place(window);
  };
  double previous = median_at(0);
  for (std::size_t i = 0; i < n; i += kMedianStride) {
    const std::size_t next = std::min(n - 1, i + kMedianStride);
    const double following = median_at(next);
    for (std::size_t k = i; k < std::min(n, i + kMedianStride); ++k) {
      const double f = next > i ? static_cast<double>(k - i) / static_cast<double>(next - i) : 0.0;
      out[k] = lx[k] - (previous + f * (following - previous));
    }
    previous = following;
  }
  return out;
}

/// Spearman's rank correlation (ties are measure-zero here: continuous energies).
double rank_correlation(const std::vector<double>& a, const std::vector<double>& b) {
  auto ranks = [](const std::vector<double>& v) {
    std::vector<std::size_t> order(v.size());
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](std::size_t p, std::size_t q) { return v[p] < v[q]; });
    std::vector<double> r(v.size());
    for (std::size_t k = 0; k < order.size(); ++k) r[order[k]] = static_cast<double>(k);
    return r;
  };
  const std::vector<double> ra = ranks(a), rb = ranks(b);
  const double mean = 0.5 * (static_cast<double>(a.size()) - 1.0);
  double sab = 0.0, saa = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    sab += (ra[i] - mean) * (rb[i] - mean);
    saa += (ra[i] - mean) * (ra[i] - mean);
  }
  return saa > 0.0 ? sab / saa : 0.0;
}

}  // namespace

LocalEventCheck check_local_events(const Eigen::Ref<const Readings>& reference_nT,
                                   const Eigen::Ref<const Readings>& test_nT, double sample_period_s,
                                   double band_high_hz, double delay_s) {
  LocalEventCheck out;
  double dt = sample_period_s;
  out.low_hz = std::max(kLowestEventHz, 2.0 * band_high_hz);
  out.high_hz = std::min(10.0 * out.low_hz, 0.4 / dt);
  if (!(out.high_hz >= 4.0 * out.low_hz)) {
    out.text = "local events not assessed: no event band above the estimation band below 0.4 / period";
    return out;
  }
  // On the records averaged in pairs of samples wherever the event band stays under 0.4 of their
  // Nyquist frequency (0.2 Hz at 1 s): the average passes R and T alike (H takes its gain) and
  // halves the work.
  const int step = 0.4 / (2.0 * sample_period_s) >= out.high_hz * (1.0 - 1e-9) ? 2 : 1;
  dt = step * sample_period_s;
  const SteppedRecord r{reference_nT, step}, t{test_nT, step};
  int length = 8;
  while (length * dt < kBlockPeriods / out.low_hz) length *= 2;
  const double df = 1.0 / (length * dt);
  const int first = static_cast<int>(std::ceil(out.low_hz / df - 1e-9));
  const int last = static_cast<int>(std::floor(out.high_hz / df + 1e-9));
  const int shift = std::isfinite(delay_s) ? static_cast<int>(std::lround(delay_s / dt)) : 0;
  const BlockSpectra s = block_spectra(r, t, length, shift, first, last, df);
  out.blocks = s.blocks;
  if (out.blocks < kMinBlocks) {
    std::ostringstream text;
    text << "local events not assessed: " << out.blocks << " blocks of " << std::lround(length * dt)
         << " s without fills (fewer than " << kMinBlocks << ")";
    out.text = text.str();
    return out;
  }
  // At each harmonic of the blocks, the transfer over every block (the test's response, filter
  // and delay, whatever their shape across the event band) and each block's residual; the
  // energies of R and of E in the event band's lower and upper halves, per block.
  const double middle_hz = std::sqrt(out.low_hz * out.high_hz);
  const std::size_t harmonics = s.frequency_hz.size(), blocks = static_cast<std::size_t>(out.blocks);
  std::vector<Complex3> a(harmonics, Complex3::Zero()), c(harmonics, Complex3::Zero()), h(harmonics);
  for (std::size_t b = 0; b < blocks; ++b) {
    for (std::size_t j = 0; j < harmonics; ++j) {
      const Row& x = s.reference[b * harmonics + j];
      a[j].noalias() += x.adjoint() * x;
      c[j].noalias() += x.adjoint() * s.test[b * harmonics + j];
    }
  }
  for (std::size_t j = 0; j < harmonics; ++j) h[j] = a[j].fullPivLu().solve(c[j]);
  Eigen::VectorXd r_low = Eigen::VectorXd::Zero(out.blocks), r_high = r_low, e_low = r_low, e_high = r_low;
  for (std::size_t b = 0; b < blocks; ++b) {
    const Eigen::Index k = static_cast<Eigen::Index>(b);
    for (std::size_t j = 0; j < harmonics; ++j) {
      const Row& x = s.reference[b * harmonics + j];
      const double r2 = x.squaredNorm(), e2 = (s.test[b * harmonics + j] - x * h[j]).squaredNorm();
      if (s.frequency_hz[j] < middle_hz) {
        r_low(k) += r2;
        e_low(k) += e2;
      } else {
        r_high(k) += r2;
        e_high(k) += e2;
      }
    }
  }
  auto series = [](const Eigen::VectorXd& v) { return local_log(std::vector<double>(v.data(), v.data() + v.size())); };
  const double root = std::sqrt(static_cast<double>(out.blocks) - 1.0);
  const double z1 = rank_correlation(series(r_low), series(e_high)) * root;
  const double z2 = rank_correlation(series(r_high), series(e_low)) * root;
  out.z = (z1 + z2) / std::sqrt(2.0);
  out.p_value = 0.5 * std::erfc(out.z / std::sqrt(2.0));
  out.assessed = true;
  out.seen = out.p_value < kLocalEventAlpha;
  std::ostringstream text;
  text.precision(2);
  text << "events at " << out.low_hz << "-" << out.high_hz << " Hz in the reference and in T - R H over "
       << out.blocks << " blocks of " << std::lround(length * dt) << " s (" << s.skipped
       << " with fills left out): z " << out.z << ", p " << out.p_value
       << (out.seen ? ": local events the test does not follow as the field (traffic, a machine); not vouched for, "
                      "give a remote reference"
                    : ": none seen");
  out.text = text.str();
  return out;
}

}  // namespace magnetometer_insitu_calibration
