// Frequency-domain weighted least squares estimator (FD-WLSE) of the calibration matrix,
// Eq. 2 of Marusenkov et al. after Nielsen (2005, J. Time Ser. Anal. 26, 279-304): the plain
// method behind WindowEstimator (window_estimator.hpp, the estimators' front door).
#pragma once

#include "magnetometer_insitu_calibration/estimation/estimator_settings.hpp"
#include "magnetometer_insitu_calibration/estimation/window_estimator.hpp"  // WindowEstimate, WindowInputs
#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <Eigen/Core>

#include <complex>
#include <memory>
#include <mutex>

namespace magnetometer_insitu_calibration {

/// FFTW's planner is not thread-safe: every FFTW plan made or destroyed in the core takes this lock.
std::mutex& fftw_planner_lock();

/// Quality figures and rules shared by every estimator: sets e.condition_number from the 3x3
/// field block of A (strongest / weakest in-band signal direction), then e.quality and
/// e.quality_text from `harmonics` (described as `harmonics_noun`, e.g. "harmonics"),
/// e.condition_number and e.coherence against the settings' rules, first failure wins.
void apply_quality_rules(WindowEstimate& e, const Eigen::Matrix3d& field_block_of_a, long harmonics,
                         const char* harmonics_noun, const EstimatorSettings& settings);

/// Estimates n from reference R and test T (N x 3, nT, regular sample period, no NaN).
/// Holds FFTW plans and buffers; reuses them while N stays the same. One instance per thread.
class FdWlseEstimator {
 public:
  explicit FdWlseEstimator(EstimatorSettings settings = {});
  ~FdWlseEstimator();
  FdWlseEstimator(const FdWlseEstimator&) = delete;
  FdWlseEstimator& operator=(const FdWlseEstimator&) = delete;

  /// inputs: the window's remote (remote_reference.hpp; its reference noise is not used here).
  WindowEstimate estimate(const Eigen::Ref<const Readings>& reference_nT,
                          const Eigen::Ref<const Readings>& test_nT, double sample_period_s,
                          const WindowInputs& inputs = {});

  /// Bins j = 0 .. N/2 (FFTW's convention, unnormalised) of column `column` of the last
  /// estimate()'s whole-window transform: 0-2 the reference minus its mean, 3-5 the test minus
  /// its mean (nT). nullptr when the last estimate() transformed nothing (bad input). Valid
  /// until the next call.
  const std::complex<double>* last_spectrum(int column) const;

  const EstimatorSettings& settings() const { return settings_; }

  struct Workspace;  ///< FFTW plan and buffers (fd_wlse.cpp)

 private:
  EstimatorSettings settings_;
  std::unique_ptr<Workspace> workspace_;
};

}  // namespace magnetometer_insitu_calibration
