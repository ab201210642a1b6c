// A linear filter applied to one column of a record over the whole window, in the frequency
// domain, without a wrap-around step: the column's line through its first and last samples is
// taken out, the rest transformed, each harmonic multiplied by the filter's response, transformed
// back, and the line put back as the filter maps it (shifted in time by line_shift_s). Used by
// remove_modelled_filter (response_model.hpp), advance_record (delay_estimation.hpp) and the
// simulated remote observatory's frequency-dependent mixing (simulation/remote_observatory.hpp).
#pragma once

#include <Eigen/Core>

#include <complex>
#include <cstddef>
#include <vector>

struct fftw_plan_s;  // FFTW's plan (fftw3.h), made and run in column_response.cpp

namespace magnetometer_insitu_calibration {

class ColumnResponse {
 public:
  /// Plans for columns of n samples (n >= 4).
  explicit ColumnResponse(std::size_t n);
  ~ColumnResponse();
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
    transform_forward();
    const double df = 1.0 / (static_cast<double>(n_) * dt);  // Hz
    for (std::size_t j = 0; j < n_ / 2 + 1; ++j) {
      spectrum_[j] = std::complex<double>(spectrum_[j].real(), spectrum_[j].imag()) *
                     response(static_cast<double>(j) * df) / static_cast<double>(n_);
    }
    if (n_ % 2 == 0) spectrum_[n_ / 2].imag(0.0);  // the Nyquist term of a real series is real
    transform_backward();
    for (std::size_t i = 0; i < n_; ++i) {
      out(static_cast<Eigen::Index>(i)) = buffer_[i] + first + slope * (static_cast<double>(i) * dt + line_shift_s);
    }
  }

 private:
  void transform_forward();   ///< buffer_ -> spectrum_
  void transform_backward();  ///< spectrum_ -> buffer_ (unnormalised)

  std::size_t n_;
  std::vector<double> buffer_;                  ///< n samples
  std::vector<std::complex<double>> spectrum_;  ///< bins 0 .. n/2
  fftw_plan_s* forward_ = nullptr;
  fftw_plan_s* backward_ = nullptr;
};

}  // namespace magnetometer_insitu_calibration
