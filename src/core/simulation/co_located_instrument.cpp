// A further instrument beside a simulated pair: see co_located_instrument.hpp.
#include "magnetometer_insitu_calibration/simulation/co_located_instrument.hpp"

#include "magnetometer_insitu_calibration/estimation/calibration_matrix.hpp"

#include <random>

namespace magnetometer_insitu_calibration {

Eigen::Matrix3d co_located_instrument_matrix() {
  return matrix_from_angles(Eigen::Vector3d(1.0003, 0.9995, 1.0002), Eigen::Vector3d(0.02, -0.01, 0.0),
                            Eigen::Vector3d(-0.1, 0.2, 0.05));
}

Readings co_located_instrument(const Readings& field_nT, const Eigen::Matrix3d& n, double white_nT,
                               std::uint64_t rng_seed) {
  Readings out = field_nT * n;
  std::mt19937_64 rng(rng_seed);
  std::normal_distribution<double> normal;
  for (Eigen::Index i = 0; i < out.rows(); ++i)
    for (int c = 0; c < 3; ++c) out(i, c) += white_nT * normal(rng);
  return out;
}

}  // namespace magnetometer_insitu_calibration
