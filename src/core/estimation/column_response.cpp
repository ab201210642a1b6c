// The whole-window column filter's FFTW plans (column_response.hpp).
#include "magnetometer_insitu_calibration/estimation/column_response.hpp"

#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"  // fftw_planner_lock

#include <fftw3.h>

#include <mutex>

namespace magnetometer_insitu_calibration {

namespace {
/// std::complex<double> and fftw_complex share their layout (FFTW's manual, "Complex numbers").
fftw_complex* as_fftw(std::complex<double>* values) { return reinterpret_cast<fftw_complex*>(values); }
}  // namespace

ColumnResponse::ColumnResponse(std::size_t n) : n_(n), buffer_(n), spectrum_(n / 2 + 1) {
  std::lock_guard<std::mutex> lock(fftw_planner_lock());
  forward_ = fftw_plan_dft_r2c_1d(static_cast<int>(n), buffer_.data(), as_fftw(spectrum_.data()), FFTW_ESTIMATE);
  backward_ = fftw_plan_dft_c2r_1d(static_cast<int>(n), as_fftw(spectrum_.data()), buffer_.data(), FFTW_ESTIMATE);
}

ColumnResponse::~ColumnResponse() {
  std::lock_guard<std::mutex> lock(fftw_planner_lock());
  fftw_destroy_plan(forward_);
  fftw_destroy_plan(backward_);
}

void ColumnResponse::transform_forward() { fftw_execute(forward_); }

void ColumnResponse::transform_backward() { fftw_execute(backward_); }

}  // namespace magnetometer_insitu_calibration
