// Remote reference: the remote's strength, the pair-only estimate's difference, the
// instrumental-variable solve (see remote_reference.hpp).
#include "magnetometer_insitu_calibration/estimation/remote_reference.hpp"

#include "magnetometer_insitu_calibration/estimation/estimate_comparison.hpp"
#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

namespace magnetometer_insitu_calibration {

namespace {

std::string format(const char* pattern, double a, double b = 0.0, double c = 0.0, double d = 0.0) {
  char buffer[256];
  std::snprintf(buffer, sizeof(buffer), pattern, a, b, c, d);
  return buffer;
}

}  // namespace

void assess_remote_strength(RemoteReference& remote, const Eigen::Matrix3d& m_xx, const Eigen::Matrix3d& m_zz,
                            const Eigen::Matrix3d& m_zx, double effective_cells) {
  const Eigen::LDLT<Eigen::Matrix3d> zz(m_zz);
  const Eigen::LLT<Eigen::Matrix3d> xx(m_xx);
  if (zz.info() != Eigen::Success || !zz.isPositive() || !(zz.vectorD().minCoeff() > 0.0) ||
      xx.info() != Eigen::Success) {
    remote.coherence.setZero();
    remote.canonical_coherence = 0.0;
    remote.strength = 0.0;
    return;
  }
  // The part of x the remote predicts: M_xz M_zz^-1 M_zx (3 x 3, x's units squared).
  const Eigen::Matrix3d predicted = m_zx.transpose() * zz.solve(m_zx);
  remote.coherence = predicted.diagonal().cwiseQuotient(m_xx.diagonal());
  // Canonical coherences: eigenvalues of L^-1 P L^-T with M_xx = L L^T (symmetric, in [0, 1]).
  const Eigen::Matrix3d l_inverse = xx.matrixL().solve(Eigen::Matrix3d::Identity());
  const Eigen::Matrix3d whitened = l_inverse * predicted * l_inverse.transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(0.5 * (whitened + whitened.transpose()));
  const double rho2 = std::clamp(eig.eigenvalues()(0), 0.0, 1.0);
  remote.canonical_coherence = rho2;
  remote.strength = rho2 < 1.0 ? effective_cells * rho2 / (1.0 - rho2) / 3.0 : std::numeric_limits<double>::infinity();
}

void assess_pair_difference(RemoteReference& remote, const Eigen::Matrix3d& n_pair, const Eigen::Matrix3d& n_remote,
                            const Matrix9d& difference_covariance, double cells) {
  remote.pair_n = n_pair;
  remote.difference_covariance = difference_covariance;
  remote.difference_cells = cells;
  // Each parameter's difference and its standard error, from the difference's covariance
  // propagated through the decomposition at the remote's n (first order).
  const CalibrationParameters pair = decompose(n_pair);
  const CalibrationParameters spread = decompose(n_remote, difference_covariance, cells);
  const CalibrationParameters at_remote = decompose(n_remote);
  remote.smallest_parameter_p = 1.0;
  for (int k = 0; k < 9; ++k) {
    const double difference = parameter_value(pair, k).value - parameter_value(at_remote, k).value;
    const double se = parameter_value(spread, k).se;
    const double z = se > 0.0 ? difference / se : std::numeric_limits<double>::quiet_NaN();
    remote.parameter_z[static_cast<std::size_t>(k)] = z;
    // Student's t with the cells' dof: t^2 ~ F(1, cells); the normal when they are infinite.
    const double p = !std::isfinite(z)                     ? std::numeric_limits<double>::quiet_NaN()
                     : std::isfinite(cells) && cells > 0.0 ? f_tail_probability(z * z, 1.0, cells)
                                                           : chi2_tail_probability(z * z, 1.0);
    if (std::isfinite(p)) remote.smallest_parameter_p = std::min(remote.smallest_parameter_p, p);
  }
  // Jointly over the nine entries of n: Hotelling's T^2 moments, a scaled chi2 matched to them.
  Eigen::Matrix<double, 9, 1> d;
  for (int k = 0; k < 9; ++k) d(k) = n_pair(k / 3, k % 3) - n_remote(k / 3, k % 3);
  const Eigen::LDLT<Matrix9d> ldlt(difference_covariance);
  remote.joint_tested = cells >= kJointTestMinCells;
  if (ldlt.info() == Eigen::Success && ldlt.isPositive() && ldlt.vectorD().minCoeff() > 0.0) {
    remote.joint_chi2 = d.dot(ldlt.solve(d));
    const QuadraticFormMoments m = quadratic_form_moments(cells, 9);
    remote.joint_p_value = std::isfinite(m.variance) && m.variance > 0.0
                               ? chi2_tail_probability(remote.joint_chi2 * 2.0 * m.mean / m.variance,
                                                       2.0 * m.mean * m.mean / m.variance)
                               : std::numeric_limits<double>::quiet_NaN();
  }
  remote.pair_biased = remote.smallest_parameter_p < kPairBiasAlpha / 9.0 ||
                       (remote.joint_tested && remote.joint_p_value < kPairBiasAlpha);
  int worst = 0;
  for (int k = 1; k < 9; ++k) {
    if (std::abs(remote.parameter_z[static_cast<std::size_t>(k)]) > std::abs(remote.parameter_z[static_cast<std::size_t>(worst)]))
      worst = k;
  }
  remote.text += remote.pair_biased
                     ? "; the pair alone is biased (" + std::string(kParameters[static_cast<std::size_t>(worst)].name) +
                           format(" %+.1f se, joint p %.2g): a disturbance both sensors see, or the reference's noise",
                                  remote.parameter_z[static_cast<std::size_t>(worst)], remote.joint_p_value)
                     : format("; the pair alone agrees (largest %.1f se, joint p %.2g)",
                              std::abs(remote.parameter_z[static_cast<std::size_t>(worst)]), remote.joint_p_value);
}

bool instrumental_solve(const Eigen::MatrixXd& a, const Eigen::MatrixXd& c, Eigen::MatrixXd& solution,
                        Eigen::MatrixXd& a_inverse) {
  // Rows (instruments) and columns (regressors) to unit size: the trend column and the field's
  // differ by many orders of magnitude, and the remote may be in any unit.
  const Eigen::VectorXd row = a.rowwise().norm(), column = a.colwise().norm().transpose();
  if (!(row.minCoeff() > 0.0) || !(column.minCoeff() > 0.0) || !a.allFinite()) return false;
  const Eigen::VectorXd r = row.cwiseInverse(), k = column.cwiseInverse();
  const Eigen::MatrixXd scaled = r.asDiagonal() * a * k.asDiagonal();
  const Eigen::PartialPivLU<Eigen::MatrixXd> lu(scaled);
  if (!(lu.rcond() > 1e-12)) return false;
  // A = R^-1 S K^-1 -> A^-1 = K S^-1 R.
  a_inverse = k.asDiagonal() * lu.inverse() * r.asDiagonal();
  solution = a_inverse * c;
  return solution.allFinite();
}

}  // namespace magnetometer_insitu_calibration
