// Applying a calibration matrix: r = n^-T t, covariance propagation.
#include "magnetometer_insitu_calibration/ros/correction_model.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <limits>

#include <sstream>
#include <stdexcept>

namespace magnetometer_insitu_calibration {

CorrectionModel::CorrectionModel(const Eigen::Matrix3d& n, const Matrix9d& covariance, double max_condition,
                                 const Eigen::Vector3d& offset, const Eigen::Vector3d& anchor)
    : n_(n), covariance_(covariance), offset_(offset), anchor_(anchor) {
  if (!offset.allFinite()) throw std::invalid_argument("offset has non-finite entries");
  if (!anchor.allFinite()) throw std::invalid_argument("reference mean has non-finite entries");
  if (!n.allFinite()) throw std::invalid_argument("matrix has non-finite entries");
  if (!covariance.allFinite()) throw std::invalid_argument("matrix_covariance has non-finite entries");
  if ((covariance.diagonal().array() < 0.0).any()) throw std::invalid_argument("matrix_covariance has a negative variance");
  // Singular values of n: square roots of the eigenvalues of n^T n (ascending).
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(n.transpose() * n, Eigen::EigenvaluesOnly);
  const double smallest = std::sqrt(std::max(0.0, eigen.eigenvalues()(0)));
  const double largest = std::sqrt(std::max(0.0, eigen.eigenvalues()(2)));
  if (!(smallest > 0.0) || !(std::abs(n.determinant()) > 0.0)) throw std::invalid_argument("matrix is singular");
  condition_number_ = largest / smallest;
  if (!(condition_number_ <= max_condition)) {
    std::ostringstream text;
    text << "matrix condition number " << condition_number_ << " exceeds " << max_condition;
    throw std::invalid_argument(text.str());
  }
  n_inverse_ = n.inverse();
  n_inverse_transpose_ = n_inverse_.transpose();
}

void CorrectionModel::set_temperature(double reference_C, const Eigen::Vector3d& offset_per_C,
                                      const Eigen::Vector3d& scale_per_C) {
  if (!std::isfinite(reference_C)) throw std::invalid_argument("temperature reference is not finite");
  if (!offset_per_C.allFinite()) throw std::invalid_argument("temperature offset coefficients are not finite");
  if (!scale_per_C.allFinite()) throw std::invalid_argument("temperature scale coefficients are not finite");
  has_temperature_ = true;
  temperature_reference_C_ = reference_C;
  temperature_offset_ = offset_per_C;
  temperature_scale_ = scale_per_C;
}

void CorrectionModel::set_temperature_uncertainty(const Eigen::Vector3d& apparent_se_per_C,
                                                  const Eigen::Vector3d& scale_se_per_C,
                                                  const Eigen::Vector3d& mean_test_field) {
  if (!apparent_se_per_C.allFinite() || (apparent_se_per_C.array() < 0.0).any() || !scale_se_per_C.allFinite() ||
      (scale_se_per_C.array() < 0.0).any()) {
    throw std::invalid_argument("temperature coefficient uncertainties must be finite and >= 0");
  }
  if (!mean_test_field.allFinite()) throw std::invalid_argument("the window's mean test field is not finite");
  apparent_se_ = apparent_se_per_C;
  scale_se_ = scale_se_per_C;
  mean_test_field_ = mean_test_field;
}

Eigen::Vector3d CorrectionModel::correct(const Eigen::Vector3d& test, double temperature_C) const {
  if (!has_temperature_) return correct(test);
  const double u = temperature_C - temperature_reference_C_;
  Eigen::Vector3d y;
  for (int l = 0; l < 3; ++l) {
    const double gain = 1.0 + temperature_scale_(l) * u;
    y(l) = gain > 0.0 ? (test(l) - offset_(l) - temperature_offset_(l) * u) / gain
                      : std::numeric_limits<double>::quiet_NaN();
  }
  return n_inverse_transpose_ * y;
}

Eigen::Matrix3d CorrectionModel::corrected_covariance(const Eigen::Matrix3d& test_covariance,
                                                      const Eigen::Vector3d& corrected,
                                                      bool include_calibration, double temperature_C) const {
  Eigen::Matrix3d c = n_inverse_transpose_ * test_covariance * n_inverse_;
  if (include_calibration && has_temperature_ && std::isfinite(temperature_C)) {
    const double u = temperature_C - temperature_reference_C_;
    const Eigen::Vector3d y = n_.transpose() * corrected;  // test frame, offset and temperature terms removed
    Eigen::Vector3d variance;
    for (int l = 0; l < 3; ++l) {
      const double factor = u / (1.0 + temperature_scale_(l) * u);
      const double lever = y(l) + offset_(l) - mean_test_field_(l);  // the reading's field about F
      variance(l) = factor * factor *
                    (apparent_se_(l) * apparent_se_(l) + lever * lever * scale_se_(l) * scale_se_(l));
    }
    c += n_inverse_transpose_ * variance.asDiagonal() * n_inverse_;
  }
  if (include_calibration) {
    Eigen::Matrix<double, 3, 9> jacobian;
    for (int j = 0; j < 3; ++j) {
      for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) jacobian(j, vec_index(a, b)) = -(corrected(a) - anchor_(a)) * n_inverse_(b, j);
      }
    }
    c += jacobian * covariance_ * jacobian.transpose();
  }
  return 0.5 * (c + c.transpose());
}

}  // namespace magnetometer_insitu_calibration
