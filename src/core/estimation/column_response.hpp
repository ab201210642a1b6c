// A linear filter applied to one column of a record over the whole window, in the frequency
// domain, without a wrap-around step: the column's line through its first and last samples is
// taken out, the rest transformed, each harmonic multiplied by the filter's response, transformed
// back, and the line put back as the filter maps it (shifted in time by line_shift_s). Shared by
// remove_modelled_filter (response_model.cpp), advance_record (record_shift.cpp) and the
// simulated remote observatory's frequency-dependent mixing (simulation/remote_observatory.cpp).
// Not installed: src/core only.
#pragma once

#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"  // fftw_planner_lock

#include <Eigen/Core>
#include <fftw3.h>

#include <complex>
#include <cstddef>
#include <mutex>
#include <vector>

namespace magnetometer_insitu_calibration::detail {

class ColumnResponse {
 public:
  /// Plans for columns of n samples (n >= 4).
  explicit ColumnResponse(std::size_t n) : n_(n), buffer_(n), spectrum_(n / 2 + 1) {
    std::lock_guard<std::mutex> lock(fftw_planner_lock());
    forward_ = fftw_plan_dft_r2c_1d(static_cast<int>(n), buffer_.data(), spectrum_.data(), FFTW_ESTIMATE);
    backward_ = fftw_plan_dft_c2r_1d(static_cast<int>(n), spectrum_.data(), buffer_.data(), FFTW_ESTIMATE);
  }
  ~ColumnResponse() {
    std::lock_guard<std::mutex> lock(fftw_planner_lock());
    fftw_destroy_plan(forward_);
    fftw_destroy_plan(backward_);
  }
  ColumnResponse(const ColumnResponse&) = delete;
  ColumnResponse& operator=(const ColumnResponse&) = delete;

  /// out = the filter (response(f), f in Hz at harmonic spacing 1 / (n dt)) applied to in, the
  /// line put back at t + line_shift_s. in and out: n samples at period dt (s), nT.
  template <class Response>
  void apply(const Eigen::Ref<const Eigen::VectorXd>& in, double dt, const Response& response, double line_shift_s,
             Eigen::Ref<Eigen::VectorXd> out) {
    const double first = in(0), last = in(static_cast<Eigen::Index>(n_ - 1));
    const double slope = (last - first) / (static_cast<double>(n_ - 1) * dt);  // nT/s
    for (std::size_t i = 0; i < n_; ++i) {
      buffer_[i] = in(static_cast<Eigen::Index>(i)) - (first + slope * static_cast<double>(i) * dt);
    }
    fftw_execute(forward_);
    const double df = 1.0 / (static_cast<double>(n_) * dt);
    for (std::size_t j = 0; j < n_ / 2 + 1; ++j) {
      const std::complex<double> y =
          std::complex<double>(spectrum_[j][0], spectrum_[j][1]) * response(static_cast<double>(j) * df) /
          static_cast<double>(n_);
      spectrum_[j][0] = y.real();
      spectrum_[j][1] = y.imag();
    }
    if (n_ % 2 == 0) spectrum_[n_ / 2][1] = 0.0;  // the Nyquist term of a real series is real
    fftw_execute(backward_);
    for (std::size_t i = 0; i < n_; ++i) {
      out(static_cast<Eigen::Index>(i)) = buffer_[i] + first + slope * (static_cast<double>(i) * dt + line_shift_s);
    }
  }

 private:
  std::size_t n_;
  std::vector<double> buffer_;
  std::vector<fftw_complex> spectrum_;
  fftw_plan forward_ = nullptr, backward_ = nullptr;
};

}  // namespace magnetometer_insitu_calibration::detail
