// Tolerances: see tolerances.hpp.
#include "magnetometer_insitu_calibration/common/tolerances.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <cmath>

namespace magnetometer_insitu_calibration {

namespace {

void check_positive(const Eigen::Vector3d& values, const char* field) {
  for (int i = 0; i < 3; ++i) {
    if (!(values(i) > 0.0) || !std::isfinite(values(i))) {
      throw InputError(field, "must be a positive finite tolerance (entry " + std::to_string(i) + " is " +
                                  std::to_string(values(i)) + ")");
    }
  }
}

}  // namespace

void Tolerances::validate() const {
  check_positive(scale, "scale");
  check_positive(nonorthogonality_deg, "nonorthogonality_deg");
  check_positive(misalignment_deg, "misalignment_deg");
}

}  // namespace magnetometer_insitu_calibration
