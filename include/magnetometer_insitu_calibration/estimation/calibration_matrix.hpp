// Building a calibration matrix n (T = R n, rows are samples) from scale-factor ratios,
// non-orthogonality angles and a misalignment rotation: the forward model of the simulator.
//
// Frames: column l of n is test axis l expressed in reference-frame coordinates, scaled by the
// scale-factor ratio K_test,l / K_ref,l (see decomposition.hpp, whose decompose() is the
// inverse of this construction up to the choice of the orthogonal factor).
#pragma once

#include <Eigen/Core>

namespace magnetometer_insitu_calibration {

/// Unit triad U (columns = unit axes x, y, z, in the triad's own nominal frame) whose pairwise
/// angles are 90 deg minus nonorthogonality_deg (xy, xz, yz; positive = axes closer than 90).
/// U is the symmetric positive-definite square root of the Gram matrix G (G_ll = 1,
/// G_kl = sin(nonorthogonality_kl)): the triad with these angles closest to the identity
/// (U^T U = G, U = U^T). Throws InputError("nonorthogonality_deg", ...) if the angles are not
/// finite or do not describe three independent axes (G not positive definite).
Eigen::Matrix3d unit_triad_from_nonorthogonality(const Eigen::Vector3d& nonorthogonality_deg);

/// Calibration matrix n = Q^T U diag(scale_ratio):
///  - scale_ratio: K_test,l / K_ref,l, dimensionless, > 0; equals the norm of column l of n;
///  - nonorthogonality_deg: xy, xz, yz, degrees, 90 deg minus the angle between test axes
///    (exact: the angle between columns k and l of n is 90 - nonorthogonality_kl);
///  - misalignment_deg: rotation vector (axis * angle, degrees, components about reference
///    x, y, z) of Q = exp([v]x), the reference-to-test coordinate rotation; the test axes are
///    the columns of U rotated by Q^T. When nonorthogonality_deg is zero, Q is exactly the
///    orthogonal polar factor of n^T, i.e. decompose(n).misalignment_deg == misalignment_deg.
/// Throws InputError naming the argument for non-finite values or a non-positive scale ratio.
Eigen::Matrix3d matrix_from_angles(const Eigen::Vector3d& scale_ratio,
                                   const Eigen::Vector3d& nonorthogonality_deg,
                                   const Eigen::Vector3d& misalignment_deg);

/// Rotation matrix exp([v]x) of a rotation vector v in degrees (Rodrigues), right-handed:
/// rotates vectors counter-clockwise by |v| about v / |v|. Identity for v == 0.
Eigen::Matrix3d rotation_from_vector_deg(const Eigen::Vector3d& rotation_vector_deg);

}  // namespace magnetometer_insitu_calibration
