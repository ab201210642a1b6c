// The weight functions of the robust estimator's M-step (robust_estimator.hpp, step 3): a cell's
// weight in [0, 1] from its standardised residual d, in sigma units (d = sqrt(r^2 / 3): r^2 is
// the cell's residual power over its frequency's robust scale, summed over the three
// components, mean 3 for a clean cell). The iteratively reweighted least squares
// (src/core/estimation/robust/section_irls.cpp) asks one of these for every cell's weight.
#pragma once

namespace magnetometer_insitu_calibration {

/// A weight function of the iteratively reweighted least squares.
class CellWeights {
 public:
  virtual ~CellWeights() = default;
  /// The weight, 0..1, of a cell whose standardised residual is `standardised_residual`
  /// (sigmas, >= 0; NaN gives NaN or 0, as the function says).
  virtual double weight(double standardised_residual) const = 0;
};

/// Huber's weights: 1 up to k sigmas, k / d beyond (a cell's pull on n grows no further than at
/// k sigmas). NaN gives NaN.
class HuberWeights final : public CellWeights {
 public:
  explicit HuberWeights(double k_sigmas) : k_sigmas_(k_sigmas) {}
  double weight(double standardised_residual) const override;
  double k_sigmas() const { return k_sigmas_; }

 private:
  double k_sigmas_;
};

/// Least squares: every cell weight 1.
class UnitWeights final : public CellWeights {
 public:
  double weight(double standardised_residual) const override;
};

/// Another weight function with the cells beyond `limit_sigmas` rejected (weight 0; NaN is not
/// beyond): the hard cut the M-step turns to once the scale and n have settled.
class RejectingWeights final : public CellWeights {
 public:
  /// `inner` must outlive this object.
  RejectingWeights(const CellWeights& inner, double limit_sigmas) : inner_(inner), limit_sigmas_(limit_sigmas) {}
  double weight(double standardised_residual) const override;

 private:
  const CellWeights& inner_;
  double limit_sigmas_;
};

}  // namespace magnetometer_insitu_calibration
