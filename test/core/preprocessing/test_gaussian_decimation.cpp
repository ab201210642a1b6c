// Gaussian FIR decimation: gain and phase against the analytic response, stop band, epochs,
// grid offsets, gap handling, and streaming == batch.
#include "magnetometer_insitu_calibration/preprocessing/gaussian_decimation.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "test_constants.hpp"

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

namespace mic = magnetometer_insitu_calibration;

namespace {

using magnetometer_insitu_calibration::test::kPi;
constexpr double kDecimationStart = 1747180800.0;  // 2025-05-14T00:00:00Z, a whole second
constexpr double kAmplitude = 10.0;      // nT

/// 10 Hz record over [kDecimationStart + offset, kDecimationStart + offset + duration), value(t - kDecimationStart) per row.
mic::VectorRecord sampled(double duration_s, double offset_s,
                          const std::function<Eigen::RowVector3d(double)>& value) {
  mic::VectorRecord r;
  r.source = "synthetic 10 Hz";
  const int n = static_cast<int>(std::lround(duration_s * 10.0));
  r.values_nT.resize(n, 3);
  for (int k = 0; k < n; ++k) {
    const double u = offset_s + 0.1 * k;  // s since kDecimationStart
    r.time_s.push_back(kDecimationStart + u);
    r.values_nT.row(k) = value(u);
  }
  return r;
}

std::function<Eigen::RowVector3d(double)> sinusoid(double f_hz) {
  return [f_hz](double u) {
    return Eigen::RowVector3d(kAmplitude * std::sin(2 * kPi * f_hz * u),
                              kAmplitude * std::sin(2 * kPi * f_hz * u + 1.0),
                              kAmplitude * std::cos(2 * kPi * f_hz * u) + 48000.0);
  };
}

/// Least-squares amplitude and phase of column c of y against sin/cos at f, phase relative to
/// sin(2 pi f (t - kDecimationStart)).
void fit_sinusoid(const mic::VectorRecord& y, int c, double f_hz, double offset_nT, double* amplitude,
                  double* phase) {
  Eigen::Matrix2d a = Eigen::Matrix2d::Zero();
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  for (std::size_t k = 0; k < y.size(); ++k) {
    const double u = y.time_s[k] - kDecimationStart;
    const Eigen::Vector2d basis(std::sin(2 * kPi * f_hz * u), std::cos(2 * kPi * f_hz * u));
    a += basis * basis.transpose();
    b += basis * (y.values_nT(static_cast<Eigen::Index>(k), c) - offset_nT);
  }
  const Eigen::Vector2d sc = a.ldlt().solve(b);
  *amplitude = std::hypot(sc(0), sc(1));
  *phase = std::atan2(sc(1), sc(0));
}

}  // namespace

TEST(GaussianDecimation, DefaultSigmaGivesOnePercentAtOutputNyquist) {
  const mic::DecimationSettings settings;
  EXPECT_NEAR(settings.effective_sigma_s(), 0.966024, 1e-6);
  EXPECT_NEAR(mic::gaussian_gain(settings.effective_sigma_s(), 0.5), 0.01, 1e-12);
  mic::DecimationSettings two_s;
  two_s.output_period_s = 2.0;
  EXPECT_NEAR(mic::gaussian_gain(two_s.effective_sigma_s(), 0.25), 0.01, 1e-12);
}

TEST(GaussianDecimation, GainEqualsAnalyticGaussianResponse) {
  const mic::DecimationSettings settings;
  const double sigma = settings.effective_sigma_s();
  for (double f : {0.002, 0.01, 0.05, 0.1, 0.2, 0.3, 0.4, 0.45}) {
    const mic::VectorRecord y = mic::decimate(sampled(1200.0, 0.0, sinusoid(f)), settings);
    ASSERT_TRUE(y.values_nT.allFinite());
    double amplitude = 0, phase = 0;
    fit_sinusoid(y, 0, f, 0.0, &amplitude, &phase);
    EXPECT_NEAR(amplitude / kAmplitude, mic::gaussian_gain(sigma, f), 1e-3) << "f = " << f << " Hz";
  }
}

TEST(GaussianDecimation, KeepsAmplitudeAndPhaseAtTheTopOfTheBandOnWholeSecondEpochs) {
  const double f = 0.01;
  const mic::DecimationSettings settings;
  const mic::VectorRecord y = mic::decimate(sampled(3600.0, 0.0, sinusoid(f)), settings);
  const double gain = mic::gaussian_gain(settings.effective_sigma_s(), f);  // 0.99816
  ASSERT_GT(y.size(), 3500u);
  for (std::size_t k = 0; k < y.size(); ++k) {
    EXPECT_EQ(y.time_s[k], std::round(y.time_s[k]));  // whole UNIX seconds
    if (k > 0) {
      EXPECT_EQ(y.time_s[k] - y.time_s[k - 1], 1.0);
    }
  }
  const double phases[] = {0.0, 1.0, kPi / 2};
  for (int c = 0; c < 3; ++c) {
    double amplitude = 0, phase = 0;
    fit_sinusoid(y, c, f, c == 2 ? 48000.0 : 0.0, &amplitude, &phase);
    EXPECT_NEAR(amplitude, kAmplitude * gain, 1e-4 * kAmplitude);
    EXPECT_NEAR(phase, phases[c], 1e-6);  // a 1 ms delay would be 6e-5 rad
  }
  // Pointwise: every output equals the analytic filtered sinusoid.
  for (std::size_t k = 0; k < y.size(); ++k) {
    const double u = y.time_s[k] - kDecimationStart;
    EXPECT_NEAR(y.values_nT(static_cast<Eigen::Index>(k), 0), gain * kAmplitude * std::sin(2 * kPi * f * u), 2e-4);
  }
}

TEST(GaussianDecimation, ToneNearInputNyquistIsSuppressed) {
  const mic::VectorRecord y = mic::decimate(sampled(600.0, 0.0, sinusoid(4.9)), mic::DecimationSettings{});
  ASSERT_GT(y.size(), 500u);
  const double worst = (y.values_nT.col(0)).cwiseAbs().maxCoeff();
  EXPECT_LT(worst, 0.01 * kAmplitude);
  EXPECT_LT(worst, 1e-4 * kAmplitude);  // truncation of the kernel at 4 sigma limits the stop band
  RecordProperty("gain_at_4_9_hz", std::to_string(worst / kAmplitude));
}

TEST(GaussianDecimation, KernelIsCentredOnTheOutputEpochWhateverTheInputGridOffset) {
  // LEMI-025: readings at t_gps - 0.3 s + 0.1 k. Also an offset that is off the 0.1 s grid, where
  // a kernel centred on the nearest input sample would be 37 ms late (0.012 A at 0.05 Hz).
  const double f = 0.05;
  const mic::DecimationSettings settings;
  const double gain = mic::gaussian_gain(settings.effective_sigma_s(), f);
  for (double offset : {-0.3, -0.037, 0.05}) {
    const mic::VectorRecord y = mic::decimate(sampled(600.0, offset, sinusoid(f)), settings);
    ASSERT_GT(y.size(), 580u);
    EXPECT_EQ(y.time_s.front(), std::round(y.time_s.front()));
    double worst = 0;
    for (std::size_t k = 0; k < y.size(); ++k) {
      const double u = y.time_s[k] - kDecimationStart;
      worst = std::max(worst, std::abs(y.values_nT(static_cast<Eigen::Index>(k), 0) -
                                       gain * kAmplitude * std::sin(2 * kPi * f * u)));
    }
    EXPECT_LT(worst, 1e-4 * kAmplitude) << "offset " << offset << " s";
  }
}

TEST(GaussianDecimation, OutputEpochsAreThoseWhoseSupportLiesInsideTheRecord) {
  // Input kDecimationStart .. kDecimationStart + 599.9; h = 4 sigma = 3.864 s: first output kDecimationStart + 4, last + 596.
  const mic::DecimationSettings settings;
  const mic::VectorRecord y = mic::decimate(sampled(600.0, 0.0, sinusoid(0.01)), settings);
  ASSERT_EQ(y.size(), 593u);
  EXPECT_EQ(y.time_s.front(), kDecimationStart + 4.0);
  EXPECT_EQ(y.time_s.back(), kDecimationStart + 596.0);
  // A constant passes unchanged (kernel of unit sum).
  const mic::VectorRecord c = mic::decimate(
      sampled(60.0, -0.3, [](double) { return Eigen::RowVector3d(20000.0, -5.0, 45000.0); }), settings);
  EXPECT_LT((c.values_nT.rowwise() - Eigen::RowVector3d(20000.0, -5.0, 45000.0)).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(GaussianDecimation, NaNOrMissingSampleInTheSupportGivesNaN) {
  mic::VectorRecord x = sampled(600.0, 0.0, sinusoid(0.01));
  x.values_nT(1000, 1) = std::nan("");  // t = kDecimationStart + 100.0, one component
  // Remove the sample at kDecimationStart + 200.0 (index 2000).
  x.time_s.erase(x.time_s.begin() + 2000);
  mic::Readings v(x.values_nT.rows() - 1, 3);
  v << x.values_nT.topRows(2000), x.values_nT.bottomRows(x.values_nT.rows() - 2001);
  x.values_nT = v;
  const mic::VectorRecord y = mic::decimate(x, mic::DecimationSettings{});
  // NaN at 100: outputs with |t_o - 100| <= 3.864 -> 97..103. Gap (199.9, 200.1) overlaps the
  // support of 197..203.
  for (std::size_t k = 0; k < y.size(); ++k) {
    const double u = y.time_s[k] - kDecimationStart;
    const bool expect_nan = (u >= 97 && u <= 103) || (u >= 197 && u <= 203);
    EXPECT_EQ(std::isnan(y.values_nT(static_cast<Eigen::Index>(k), 0)), expect_nan) << u;
    EXPECT_EQ(std::isnan(y.values_nT(static_cast<Eigen::Index>(k), 2)), expect_nan) << u;
  }
}

TEST(GaussianDecimation, StreamingEqualsBatch) {
  // Random-walk signal on the LEMI grid (-0.3 s), with NaN values, a one-sample and a 30 s gap.
  std::mt19937 rng(7);
  std::normal_distribution<double> step(0.0, 0.3);
  Eigen::RowVector3d level(20000.0, 100.0, 45000.0);
  mic::VectorRecord x = sampled(900.0, -0.3, [&](double) {
    level += Eigen::RowVector3d(step(rng), step(rng), step(rng));
    return level;
  });
  x.values_nT(1234, 0) = std::nan("");
  x.values_nT(4321, 2) = std::nan("");
  mic::VectorRecord gappy;
  gappy.source = x.source;
  std::vector<Eigen::RowVector3d> rows;
  for (std::size_t k = 0; k < x.size(); ++k) {
    if (k == 2000 || (k >= 5000 && k < 5300)) continue;
    gappy.time_s.push_back(x.time_s[k]);
    rows.push_back(x.values_nT.row(static_cast<Eigen::Index>(k)));
  }
  gappy.values_nT.resize(static_cast<Eigen::Index>(rows.size()), 3);
  for (std::size_t k = 0; k < rows.size(); ++k) gappy.values_nT.row(static_cast<Eigen::Index>(k)) = rows[k];

  const mic::DecimationSettings settings;
  const mic::VectorRecord batch = mic::decimate(gappy, settings);
  mic::StreamingDecimator stream(0.1, settings);
  std::vector<std::pair<double, Eigen::Vector3d>> streamed;
  for (std::size_t k = 0; k < gappy.size(); ++k) {
    for (auto& o : stream.push(gappy.time_s[k], gappy.values_nT.row(static_cast<Eigen::Index>(k)).transpose())) {
      streamed.push_back(o);
    }
    ASSERT_LT(stream.buffered(), 400u);  // bounded: about the support plus one gap
  }
  ASSERT_EQ(streamed.size(), batch.size());
  std::size_t nan_count = 0;
  for (std::size_t k = 0; k < batch.size(); ++k) {
    EXPECT_EQ(streamed[k].first, batch.time_s[k]);
    for (int c = 0; c < 3; ++c) {
      const double b = batch.values_nT(static_cast<Eigen::Index>(k), c), s = streamed[k].second(c);
      if (std::isnan(b)) {
        EXPECT_TRUE(std::isnan(s)) << k;
        ++nan_count;
      } else {
        EXPECT_NEAR(s, b, 1e-12 * std::abs(b)) << k;
      }
    }
  }
  EXPECT_GT(nan_count, 30u);  // the gaps really produced NaN outputs
  EXPECT_LT(nan_count, 200u);

  // Reset starts a new record; out-of-order samples are ignored and counted.
  stream.reset();
  EXPECT_TRUE(stream.push(kDecimationStart, Eigen::Vector3d::Zero()).empty());
  EXPECT_TRUE(stream.push(kDecimationStart - 1.0, Eigen::Vector3d::Zero()).empty());
  EXPECT_EQ(stream.rejected(), 1u);
}

TEST(GaussianDecimation, StreamingRestartsOnAClockJumpInsteadOfFloodingOrBlocking) {
  const mic::DecimationSettings settings;
  mic::StreamingDecimator stream(0.1, settings, 600.0);
  const Eigen::Vector3d v(1.0, 2.0, 3.0);
  std::size_t outputs = 0;
  for (int k = 0; k < 600; ++k) outputs += stream.push(kDecimationStart + 0.1 * k, v).size();
  EXPECT_EQ(outputs, 53u);  // epochs kDecimationStart + 4 .. kDecimationStart + 56 (t_o - h > kDecimationStart, t_o + h < kDecimationStart + 59.9)
  // One stamp a year ahead: a new record, no year of NaN outputs.
  EXPECT_TRUE(stream.push(kDecimationStart + 3.15e7, v).empty());
  EXPECT_EQ(stream.restarts(), 1u);
  // Normal stamps again: a second restart, then normal outputs with the same values.
  std::vector<std::pair<double, Eigen::Vector3d>> after;
  for (int k = 600; k < 1200; ++k) {
    for (auto& o : stream.push(kDecimationStart + 0.1 * k, v)) after.push_back(o);
  }
  EXPECT_EQ(stream.restarts(), 2u);
  EXPECT_EQ(stream.rejected(), 0u);
  ASSERT_EQ(after.size(), 53u);  // kDecimationStart + 64 .. kDecimationStart + 116
  EXPECT_EQ(after.front().first, kDecimationStart + 64.0);
  EXPECT_LT((after.back().second - v).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(GaussianDecimation, RejectsBadInputAndSettings) {
  mic::VectorRecord x = sampled(60.0, 0.0, sinusoid(0.01));
  x.time_s[100] = x.time_s[99];
  try {
    mic::decimate(x, mic::DecimationSettings{});
    FAIL() << "no exception";
  } catch (const mic::InputError& e) {
    EXPECT_EQ(e.where(), "synthetic 10 Hz");
    EXPECT_NE(e.problem().find("sample 100"), std::string::npos) << e.what();
  }
  mic::DecimationSettings bad;
  bad.sigma_s = 0.01;  // support 0.04 s: shorter than the 0.1 s input period
  EXPECT_THROW(mic::decimate(sampled(60.0, 0.0, sinusoid(0.01)), bad), mic::InputError);
  EXPECT_THROW(mic::StreamingDecimator(0.1, bad), mic::InputError);
  bad = {};
  bad.output_period_s = -1.0;
  EXPECT_THROW(mic::StreamingDecimator(0.1, bad), mic::InputError);
}

// A scalar magnetometer's F through the pair's low-pass (decimate_scalar): at 1 s, 0.37 s off the
// whole seconds, a tone comes out on the whole seconds with the decimation's gain and no phase,
// as the pair decimated from 10 Hz gets it; F every 30 s comes back unchanged.
TEST(GaussianDecimation, ScalarDecimationGivesFThePairsGainOnItsEpochs) {
  const mic::DecimationSettings settings;  // 10 Hz -> 1 s
  const double sigma = settings.effective_sigma_s();
  for (double f : {0.002, 0.01, 0.05, 0.1}) {
    mic::ScalarRecord s;
    for (int k = 0; k < 3600; ++k) {
      s.time_s.push_back(kDecimationStart + 0.37 + k);
      s.value_nT.push_back(48000.0 + kAmplitude * std::sin(2 * kPi * f * (0.37 + k)));
    }
    const mic::ScalarRecord y = mic::decimate_scalar(s, settings);
    mic::VectorRecord as_vector;
    as_vector.time_s = y.time_s;
    as_vector.values_nT.resize(static_cast<Eigen::Index>(y.size()), 3);
    for (std::size_t k = 0; k < y.size(); ++k) {
      EXPECT_DOUBLE_EQ(y.time_s[k], std::round(y.time_s[k])) << "not on a whole second";
      as_vector.values_nT.row(static_cast<Eigen::Index>(k)).setConstant(y.value_nT[k]);
    }
    ASSERT_TRUE(as_vector.values_nT.allFinite());
    EXPECT_GT(y.size(), 3590u);
    double amplitude = 0, phase = 0;
    fit_sinusoid(as_vector, 0, f, 48000.0, &amplitude, &phase);
    // The kernel sampled every second and cut at 4 sigma: within 5e-4 of the analytic gain
    // (measured 1.0e-4 at 0.05 Hz, 2.6e-4 at 0.1 Hz), against the 4.5 % at 0.05 Hz it matches.
    EXPECT_NEAR(amplitude / kAmplitude, mic::gaussian_gain(sigma, f), 5e-4) << "f = " << f << " Hz";
    EXPECT_NEAR(phase, 0.0, 1e-4) << "f = " << f << " Hz";  // measured up to 1.1e-5 rad
  }
  mic::ScalarRecord sparse;
  for (int k = 0; k < 100; ++k) {
    sparse.time_s.push_back(kDecimationStart + 0.37 + 30.0 * k);
    sparse.value_nT.push_back(48000.0 + k);
  }
  const mic::ScalarRecord same = mic::decimate_scalar(sparse, settings);
  EXPECT_EQ(same.time_s, sparse.time_s);
  EXPECT_EQ(same.value_nT, sparse.value_nT);
}
