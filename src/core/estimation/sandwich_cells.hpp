// How many independent spectral cells a sandwich covariance of n rests on (WindowEstimate::
// covariance_dof). The sandwich sums one score per cell, s_i = w_i Re(x_i conj(e_i)) for each of
// the three columns; its expected value is Omega = sum_i w_i^2 sigma_i^2 Re(x_i x_i^H) per column,
// sigma_i^2 the residual power the estimator assumes for the cell (its scale bin's; plain Eq. 2,
// one power per column). Cell i's share of the whitened sum,
//   t_i = sum_l w_i^2 sigma_il^2 x_i^H Omega_l^-1 x_i,        sum_i t_i = 3 p,
// counts as one cell when all cells share equally and as more than one when it dominates; the
// Satterthwaite count (sum t)^2 / sum t^2 (Bell and McCaffrey 2002; Pustejovsky and Tipton 2018
// for Hotelling's T^2 with such a count) is the cells' number when they share equally and fewer
// when a few carry most of the sandwich, as the band's strong lowest harmonics do under a red
// geomagnetic spectrum (docs/validation.md, coverage of the intervals). Not installed: src/core
// only.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <array>
#include <cmath>
#include <complex>
#include <limits>

namespace magnetometer_insitu_calibration::detail {

/// Two passes over the same cells: add() each, then share() of each, then count().
/// x: the cell's regressor DFT (p entries, scaled as the caller likes, the same in both passes);
/// w: its weight in the estimating equation; sigma2: residual power per column, any unit.
class SandwichCells {
 public:
  using VectorXcd = Eigen::Matrix<std::complex<double>, Eigen::Dynamic, 1>;

  explicit SandwichCells(int p) {
    for (Eigen::MatrixXd& m : expected_) m = Eigen::MatrixXd::Zero(p, p);
  }

  void add(const VectorXcd& x, double w, const Eigen::Vector3d& sigma2) {
    const Eigen::MatrixXd xx = (x * x.adjoint()).real();
    for (int l = 0; l < 3; ++l) expected_[l].noalias() += w * w * sigma2(l) * xx;
  }

  /// Cell x's share t; false when an expected column sum is singular (no count then).
  bool share(const VectorXcd& x, double w, const Eigen::Vector3d& sigma2) {
    if (!solved_) solve();
    if (!ok_) return false;
    double t = 0.0;
    for (int l = 0; l < 3; ++l) t += w * w * sigma2(l) * (x.adjoint() * inverses_[l] * x)(0, 0).real();
    sum_ += t;
    sum_squares_ += t * t;
    return true;
  }

  /// (sum t)^2 / sum t^2; NaN when a column sum was singular or nothing was shared.
  double count() const {
    if (!ok_ || !(sum_squares_ > 0.0)) return std::numeric_limits<double>::quiet_NaN();
    return sum_ * sum_ / sum_squares_;
  }

 private:
  void solve() {
    solved_ = true;
    ok_ = true;
    for (int l = 0; l < 3; ++l) {
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(expected_[l]);
      if (ldlt.info() != Eigen::Success || !ldlt.isPositive() || !(ldlt.vectorD().minCoeff() > 0.0)) {
        ok_ = false;
        return;
      }
      inverses_[l] = ldlt.solve(Eigen::MatrixXd::Identity(expected_[l].rows(), expected_[l].cols()));
    }
  }

  std::array<Eigen::MatrixXd, 3> expected_, inverses_;
  bool solved_ = false, ok_ = false;
  double sum_ = 0.0, sum_squares_ = 0.0;
};

}  // namespace magnetometer_insitu_calibration::detail
