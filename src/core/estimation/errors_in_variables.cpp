// Errors-in-variables correction: see errors_in_variables.hpp for the reasoning.
#include "magnetometer_insitu_calibration/estimation/errors_in_variables.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include <cmath>
#include <limits>

namespace magnetometer_insitu_calibration {

Eigen::Vector3d NoiseSpectrum::psd(double frequency_hz, double sample_period_s) const {
  const Eigen::Vector3d white = 2.0 * sample_period_s * white_nT.cwiseAbs2();
  const Eigen::Vector3d pink = pink_nT_per_sqrt_hz.cwiseAbs2() / std::max(frequency_hz, 1e-12);
  return white + pink;
}

Eigen::Vector3d NoiseSpectrum::expected_periodogram(double frequency_hz, double sample_period_s,
                                                    std::size_t length) const {
  return static_cast<double>(length) * psd(frequency_hz, sample_period_s) / (2.0 * sample_period_s);
}

double reference_share_of_residual(double noise_ratio) {
  if (!(noise_ratio >= 0.0)) return 0.0;
  if (std::isinf(noise_ratio)) return 1.0;
  return noise_ratio / (1.0 + noise_ratio);
}

bool corrected_solve(const Eigen::MatrixXd& a, const Eigen::Matrix3d& noise, const Eigen::MatrixXd& c,
                     Eigen::MatrixXd& solution, Eigen::MatrixXd* corrected_inverse) {
  Eigen::MatrixXd ac = a;
  ac.topLeftCorner<3, 3>() -= noise;
  if ((ac.diagonal().array() <= 0.0).any()) return false;
  // Scale to unit diagonal (the trend column and the field columns differ by many orders).
  const Eigen::VectorXd scale = ac.diagonal().cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd scaled = scale.asDiagonal() * ac * scale.asDiagonal();
  const Eigen::LLT<Eigen::MatrixXd> llt(scaled);
  if (llt.info() != Eigen::Success) return false;
  const Eigen::MatrixXd inverse =
      scale.asDiagonal() * llt.solve(Eigen::MatrixXd::Identity(a.rows(), a.cols())) * scale.asDiagonal();
  solution = inverse * c;
  if (corrected_inverse != nullptr) *corrected_inverse = inverse;
  return true;
}

Eigen::Matrix3d eiv_attenuation(const Eigen::Matrix3d& signal, const Eigen::Matrix3d& noise) {
  return (signal + noise).inverse() * noise;
}

}  // namespace magnetometer_insitu_calibration
