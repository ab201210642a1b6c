// The scalar check of one window: see scalar_window.hpp.
#include "magnetometer_insitu_calibration/pipeline/scalar_window.hpp"

#include "magnetometer_insitu_calibration/common/time_steps.hpp"
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"
#include "magnetometer_insitu_calibration/pipeline/temperature_channel.hpp"
#include "magnetometer_insitu_calibration/preprocessing/band_limited_interpolation.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <sstream>
#include <vector>

namespace magnetometer_insitu_calibration {

namespace {

/// The scalar's samples within [low_s, high_s] and their median step, s (0 with fewer than two).
double scalar_period(const ScalarRecord& s, double low_s, double high_s, std::vector<double>& times,
                     std::vector<double>& values) {
  const auto lo = std::lower_bound(s.time_s.begin(), s.time_s.end(), low_s);
  const auto hi = std::upper_bound(lo, s.time_s.end(), high_s);
  times.assign(lo, hi);
  values.assign(s.value_nT.begin() + (lo - s.time_s.begin()), s.value_nT.begin() + (hi - s.time_s.begin()));
  return median_time_step(times);
}

/// The reference's noise as the fit on the scalar's own grid sees it (band_limited_interpolation.hpp):
/// white of variance w^2 white_variance + p^2 pink_alias per point, 1/f unchanged; the levels'
/// covariance through the same linear map of (w^2, p^2).
ReferenceNoiseModel noise_on_scalar_grid(ReferenceNoiseModel model, const InterpolatedNoise& passed) {
  Eigen::Matrix2d map;
  map << passed.white_variance, passed.pink_alias, 0.0, 1.0;
  for (int c = 0; c < 3; ++c) {
    const double w2 = model.spectrum.white_nT(c) * model.spectrum.white_nT(c);
    const double p2 = model.spectrum.pink_nT_per_sqrt_hz(c) * model.spectrum.pink_nT_per_sqrt_hz(c);
    model.spectrum.white_nT(c) = std::sqrt(passed.white_variance * w2 + passed.pink_alias * p2);
    auto& covariance = model.level_covariance[static_cast<std::size_t>(c)];
    covariance = map * covariance * map.transpose();
  }
  return model;
}

}  // namespace

ScalarCheck check_scalar(const ScalarRecord& scalar, const PairedRecord& window, double period_s,
                         const WindowEstimate& estimate, WindowEstimator& estimator, const WindowInputs& inputs,
                         const GapSettings& gaps, const std::optional<FieldDirection>& given,
                         const std::optional<DecimationSettings>& decimation) {
  ScalarCheck none;
  if (window.size() < 16 || !estimate.n.allFinite()) {
    none.text = "scalar check not assessed: the window has no estimate";
    return none;
  }
  std::vector<double> times, values;
  const double low_s = window.time_s.front() - 60.0, high_s = window.time_s.back() + 60.0;
  double step = scalar_period(scalar, low_s, high_s, times, values);
  if (decimation && times.size() >= 2) {  // through the pair's low-pass (unchanged when sparser)
    ScalarRecord around;
    around.time_s = times;
    around.value_nT = values;
    try {
      step = scalar_period(decimate_scalar(around, *decimation), low_s, high_s, times, values);
    } catch (const std::exception& error) {
      none.text = std::string("scalar check not assessed: ") + error.what();
      return none;
    }
  }
  if (!(step > 0.0) || times.size() < 16) {
    none.text = "scalar check not assessed: " + std::to_string(times.size()) + " scalar samples in the window";
    return none;
  }
  const bool own_grid = step > 1.5 * period_s;
  const double dt = own_grid ? step : period_s;
  std::vector<double> grid;
  if (own_grid) {  // from the scalar's first instant in the window, so that F stays on its own samples
    const auto first = std::lower_bound(times.begin(), times.end(), window.time_s.front());
    for (double t = first != times.end() ? *first : window.time_s.back() + dt; t <= window.time_s.back(); t += dt) {
      grid.push_back(t);
    }
  } else {
    grid = window.time_s;
  }
  // F on the grid (NaN across its own gaps), the reference on the same times; F thrice as the
  // "test", so that the estimator's three columns of n are each c.
  // On the window's epochs, from samples off them (a GP20S3 0.37 s off the whole seconds), a
  // straight line's loss between samples would be read as the reference's scale: cubic. On the
  // scalar's own grid F stays on its samples and the reference goes to them band-limited.
  const Eigen::VectorXd f = interpolate_channel(times, values, grid, 2.5 * step,
                                                own_grid ? ChannelInterpolation::kLinear : ChannelInterpolation::kCubic);
  PairedRecord paired;
  paired.time_s = grid;
  paired.reference_nT = own_grid ? interpolate_regular(window.reference_nT, window.time_s.front(), period_s, grid)
                                  : window.reference_nT;
  paired.test_nT = f.replicate(1, 3);
  for (Eigen::Index i = 0; i < f.size(); ++i) {
    if (!std::isfinite(f(i))) paired.reference_nT.row(i).setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  WindowInputs scalar_inputs;
  scalar_inputs.reference_noise =
      own_grid && inputs.reference_noise.has_noise()
          ? noise_on_scalar_grid(inputs.reference_noise, interpolated_noise(window.time_s.front(), period_s, grid, dt))
          : inputs.reference_noise;
  if (!own_grid && estimate.remote.used) {  // the remote's instruments serve F's fit too
    scalar_inputs.remote_nT = inputs.remote_nT;
    scalar_inputs.remote_name = inputs.remote_name;
  }
  WindowEstimate e;
  try {
    const Readings remote_copy = scalar_inputs.remote_nT != nullptr ? *scalar_inputs.remote_nT : Readings();
    regularize_and_fill(paired, dt, gaps);
    if (scalar_inputs.remote_nT != nullptr && paired.size() != static_cast<std::size_t>(remote_copy.rows())) {
      scalar_inputs.remote_nT = nullptr;  // trimmed at an edge: the epochs no longer match the remote's
    }
    e = estimator.estimate(paired.reference_nT, paired.test_nT, dt, scalar_inputs);
  } catch (const std::exception& error) {
    none.text = std::string("scalar check not assessed: ") + error.what();
    return none;
  }
  if (e.quality != Quality::kOk && e.quality != Quality::kLowCoherence) {
    none.text = "scalar check not assessed: the fit of F is " + std::string(quality_name(e.quality)) + " (" + e.quality_text + ")";
    return none;
  }
  Eigen::Matrix3d covariance;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) covariance(a, b) = e.n_covariance(vec_index(a, 0), vec_index(b, 0));
  ScalarCheck out = assess_scalar(e.n.col(0), covariance, e.covariance_dof, estimate.n, estimate.n_covariance, given);
  out.delay_s = e.delay_s;
  std::ostringstream where;
  where << " (" << (scalar.station.empty() ? std::string() : scalar.station + ", ")
        << (own_grid ? "on the scalar's own " : "on the window's ") << dt << " s grid"
        << (e.remote.used ? ", the remote's instruments" : "") << ")";
  out.text += where.str();
  return out;
}

}  // namespace magnetometer_insitu_calibration
