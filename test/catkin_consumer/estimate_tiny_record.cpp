// Calls the core's Eq. 2 estimator (FdWlseEstimator) on a tiny noise-free record: 4096 s at
// 1 s of a reference R (nT, three independent random walks) and T = R n_true + 50 nT. Prints n
// and exits 0 when every entry is within 1e-6 of n_true (1 otherwise).
#include <magnetometer_insitu_calibration/estimation/fd_wlse.hpp>

#include <Eigen/Core>

#include <cmath>
#include <cstdio>
#include <random>

int main() {
  namespace mic = magnetometer_insitu_calibration;
  const Eigen::Index samples = 4096;
  Eigen::Matrix3d n_true;
  n_true << 1.002, 0.001, -0.003, -0.002, 0.998, 0.004, 0.003, -0.004, 1.001;
  std::mt19937 generator(7);
  std::normal_distribution<double> step(0.0, 0.5);  // nT per second
  mic::Readings reference(samples, 3), test(samples, 3);
  Eigen::RowVector3d walk(20000.0, 1500.0, 44000.0);
  for (Eigen::Index i = 0; i < samples; ++i) {
    walk += Eigen::RowVector3d(step(generator), step(generator), step(generator));
    reference.row(i) = walk;
  }
  test = reference * n_true;
  test.array() += 50.0;
  mic::FdWlseEstimator estimator;
  const mic::WindowEstimate e = estimator.estimate(reference, test, 1.0);
  const double error = (e.n - n_true).cwiseAbs().maxCoeff();
  std::printf("quality %s, %d harmonics, max |n - n_true| = %.3g\n", e.quality_text.c_str(),
              e.harmonic_last - e.harmonic_first + 1, error);
  return error < 1e-6 ? 0 : 1;
}
