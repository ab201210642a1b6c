// Frequency-domain weighted least squares estimator (FD-WLSE) of the calibration matrix,
// Eq. 2 of Marusenkov et al. after Nielsen (2005, J. Time Ser. Anal. 26, 279-304).
#pragma once

#include "magnetometer_insitu_calibration/decomposition.hpp"
#include "magnetometer_insitu_calibration/vector_record.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <memory>
#include <string>

namespace magnetometer_insitu_calibration {

struct EstimatorSettings {
  double band_low_hz = 0.0002;   ///< lower band edge: harmonics below are not summed (m0)
  double band_high_hz = 0.01;    ///< upper band edge (m)
  double gamma = 1.0;            ///< weights lambda_j^gamma
  bool trend = true;             ///< add a linear-trend column to the reference
  // Quality rules: a window that breaks one is flagged, never silently accepted.
  std::size_t min_harmonics = 16;      ///< fewer harmonics in the band: TooFewHarmonics
  double max_condition_number = 1e4;   ///< of the 3x3 reference block of A: IllConditioned
  double min_coherence = 0.5;          ///< any component below: LowCoherence

  /// Throws InputError naming the field when a value is impossible.
  void validate() const;
};

enum class Quality : int {
  kOk = 0,
  kTooFewSamples = 1,
  kTooFewHarmonics = 2,
  kIllConditioned = 3,
  kLowCoherence = 4,
  kGaps = 5,
  kNotFinite = 6,
};
const char* quality_name(Quality q);  ///< "ok", "too_few_samples", ...

/// Result for one window of paired, regularly sampled, gap-free readings.
struct WindowEstimate {
  std::size_t samples = 0;
  double sample_period_s = 0.0;
  int harmonic_first = 0;  ///< m0
  int harmonic_last = 0;   ///< m
  Eigen::Matrix3d n = Eigen::Matrix3d::Identity();  ///< T = R n
  Matrix9d n_covariance = Matrix9d::Zero();         ///< covariance of row-major vec(n)
  Eigen::Vector3d trend_nT_per_day = Eigen::Vector3d::Zero();
  Eigen::Vector3d trend_stderr_nT_per_day = Eigen::Vector3d::Zero();
  CalibrationParameters parameters;                 ///< decomposition of n with 95 % intervals
  double condition_number = 0.0;
  Eigen::Vector3d coherence = Eigen::Vector3d::Zero();
  Eigen::Vector3d residual_rms_nT = Eigen::Vector3d::Zero();
  Quality quality = Quality::kOk;
  std::string quality_text = "ok";

  /// Standard errors of the nine entries of n (row-major), sqrt of the covariance diagonal.
  Eigen::Matrix3d n_stderr() const;
};

/// Estimates n from reference R and test T (N x 3, nT, regular sample period, no NaN).
/// Holds FFTW plans and buffers; reuses them while N stays the same. One instance per thread.
class FdWlseEstimator {
 public:
  explicit FdWlseEstimator(EstimatorSettings settings = {});
  ~FdWlseEstimator();
  FdWlseEstimator(const FdWlseEstimator&) = delete;
  FdWlseEstimator& operator=(const FdWlseEstimator&) = delete;

  WindowEstimate estimate(const Eigen::Ref<const Readings>& reference_nT,
                          const Eigen::Ref<const Readings>& test_nT, double sample_period_s);

  /// Only the FFTs of the same data, for the benchmark's ratio (returns a checksum).
  double transform_only(const Eigen::Ref<const Readings>& reference_nT,
                        const Eigen::Ref<const Readings>& test_nT);

  const EstimatorSettings& settings() const { return settings_; }

 private:
  struct Workspace;
  EstimatorSettings settings_;
  std::unique_ptr<Workspace> workspace_;
};

}  // namespace magnetometer_insitu_calibration
