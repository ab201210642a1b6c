// The robust estimator's cells (robust_estimator.hpp, step 2): one harmonic of one section with
// the reference's, the test's and a remote's DFT values there; and the regression that solves n
// from them, on one of two instruments: the reference's own values (least squares, corrected for
// the reference's noise when one is given) or the remote's (instrumental variables). Not
// installed: src/core only.
#pragma once

#include "magnetometer_insitu_calibration/estimation/errors_in_variables.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <limits>

namespace magnetometer_insitu_calibration::detail::robust {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kLn2 = 0.69314718055994531;

/// One harmonic of one section.
struct Cell {
  int section = 0;
  int bin = 0;           ///< scale bin (neighbouring frequencies)
  double frequency_hz = 0.0;
  long harmonic = 0;     ///< j: the cell is the section's DFT bin j (frequency_hz = j / section duration)
  double g = 0.0;        ///< lambda^gamma
  std::size_t length = 0;  ///< section length, samples
  Eigen::Vector3cd x, y;   ///< the reference's and the test's DFT, nT
  Eigen::Vector3cd z = Eigen::Vector3cd::Zero();  ///< the remote's DFT (its units); zero without one
};

/// How n is solved from the cells: least squares on the reference's own cells, corrected for a
/// reference noise when one is given (errors_in_variables.hpp); or instrumental variables on the
/// remote's cells (remote_reference.hpp), which need no correction.
struct Regression {
  /// The instruments: which DFT values of a cell n is regressed on.
  enum class Instruments {
    kOwnReference,  ///< the reference's own, cell.x: least squares
    kRemote,        ///< the remote's, cell.z: instrumental variables
  };
  const NoiseSpectrum* noise = nullptr;  ///< least squares: the reference noise to correct for (null: none)
  Instruments instruments = Instruments::kOwnReference;
  double sample_period_s = 1.0;
  bool on_remote() const { return instruments == Instruments::kRemote; }
  /// The cell's instruments: the remote's DFT, or the reference's own.
  const Eigen::Vector3cd& instrument(const Cell& cell) const { return on_remote() ? cell.z : cell.x; }
};

}  // namespace magnetometer_insitu_calibration::detail::robust
