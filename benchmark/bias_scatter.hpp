// Shared by the Monte Carlo programs: the bias of an error over seeds in units of its scatter.
#pragma once

#include <Eigen/Core>

#include <vector>

namespace monte_carlo {

/// Per component: mean / standard deviation (population) of `errors` over the seeds. Its own
/// standard error is about 1 / sqrt(errors.size()).
inline Eigen::Vector3d bias_over_scatter(const std::vector<Eigen::Vector3d>& errors) {
  const double count = static_cast<double>(errors.size());
  Eigen::Vector3d mean = Eigen::Vector3d::Zero(), sq = Eigen::Vector3d::Zero();
  for (const auto& e : errors) {
    mean += e / count;
    sq += e.cwiseAbs2() / count;
  }
  const Eigen::Vector3d scatter = (sq - mean.cwiseAbs2()).cwiseSqrt();
  return mean.cwiseQuotient(scatter);
}

}  // namespace monte_carlo
