// Remote reference: n estimated with a record that does not see the station's local
// disturbances as the instruments of the regression (magnetotellurics' remote reference:
// Gamble, Goubau & Clarke 1979, Geophysics 44; Egbert 1997, GJI 130).
//
// Why. A disturbance both sensors see (a vehicle on a road beside the hut, a heater, a tilting
// pier under both) is coherent between R and T but does not follow n, so least squares on the
// pair, however weighted, takes part of it for field and biases n. The natural field in the
// band (0.0002-0.01 Hz) is coherent over hundreds of kilometres; the local disturbance is not.
// With the remote's cells z (3 components, any orientation, scale or units), the estimating
// equation of Eq. 2 becomes an instrumental-variable one (cells c: harmonic x section, weights
// w_c g_c with g = lambda^gamma):
//   A = sum w g Re(z x^H),  C = sum w g Re(z y^H),  n = A^-1 C          (A is not symmetric)
// and its sandwich covariance A^-1 [sum s s^T] A^-T has the score s_l = w g Re(z conj(e_l)) with
// the LOCAL residual e = y - n^T x. E[z^H e] = 0 whenever the remote's noise and field are
// independent of the local instruments' errors, so neither the local disturbance nor the
// reference's own noise biases n: no errors-in-variables correction is made. Any real 3 x 3
// mixing of the remote (orientation, gains) leaves n exactly unchanged. What a remote costs is
// variance: about 1 / rho^2 in each direction, rho the canonical coherence between the remote
// and the local reference.
//
// Does the remote serve? Over the band's weighted cells, with M_uv = sum w g Re(u v^H):
//  - coherence_k = [M_xz M_zz^-1 M_zx]_kk / [M_xx]_kk, the share of local reference component k
//    the remote's three components predict;
//  - canonical coherences: the eigenvalues of M_xx^-1 M_xz M_zz^-1 M_zx; the smallest, rho_3^2,
//    is the weakest direction the remote predicts;
//  - the instruments' strength, the first-stage F = N_eff rho_3^2 / (1 - rho_3^2) / 3 with
//    N_eff = 2 (sum w g)^2 / sum (w g)^2 (two real equations per cell). Below kMinRemoteStrength
//    (Staiger & Stock 1997; Stock & Yogo 2005) an instrumental-variable estimate is biased towards
//    least squares and its intervals are too narrow: the remote is refused and the window is
//    the pair's, with the reason. A remote of a different field, or on a wrong time base (hours
//    off), has rho_3^2 near 3 / N_eff and F near 1.
//
// Does the pair alone do as well? The pair-only estimate (least squares with the same final
// weights, with the pair's errors-in-variables correction when it has a noise model) against the
// remote's: d = vec(n_pair - n_remote), its covariance from the per-cell difference of the two
// estimators' influence (cells independent; in the robust estimator raised to the jackknife over
// the same groups, as n's own), a joint chi2 over the nine entries and each parameter's
// difference; the pair is called biased by the rule of estimate_comparison.hpp at
// kPairBiasAlpha.
#pragma once

#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"

#include <Eigen/Core>

#include <array>
#include <limits>
#include <string>

namespace magnetometer_insitu_calibration {

/// Fewest first-stage F of the remote's instruments for an instrumental-variable estimate.
constexpr double kMinRemoteStrength = 10.0;
/// Level of the test that calls the pair-only estimate biased (at most about twice it in false
/// calls when the pair is not biased and the intervals are honest).
constexpr double kPairBiasAlpha = 0.01;

/// What a remote did in a window: whether n rests on it, how well it predicts the local
/// reference, and how the pair-only estimate compares.
struct RemoteReference {
  bool given = false;  ///< a remote record came with the window
  bool used = false;   ///< n is the instrumental-variable estimate on it
  std::string text;    ///< what was done, or why the remote was refused
  /// Share of each local reference component the remote predicts over the band's weighted cells.
  Eigen::Vector3d coherence = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  double canonical_coherence = std::numeric_limits<double>::quiet_NaN();  ///< the smallest, rho_3^2
  double strength = std::numeric_limits<double>::quiet_NaN();             ///< first-stage F
  // The pair-only estimate on the same cells and weights, and its difference from n (used only).
  Eigen::Matrix3d pair_n = Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Matrix9d difference_covariance = Matrix9d::Constant(std::numeric_limits<double>::quiet_NaN());
  double difference_cells = std::numeric_limits<double>::quiet_NaN();  ///< dof of that covariance
  /// Per parameter (estimate_comparison.hpp's order): (pair - remote) / its standard error.
  std::array<double, 9> parameter_z{};
  double smallest_parameter_p = std::numeric_limits<double>::quiet_NaN();
  double joint_chi2 = std::numeric_limits<double>::quiet_NaN();
  double joint_p_value = std::numeric_limits<double>::quiet_NaN();
  bool joint_tested = false;  ///< the difference's covariance rests on enough cells
  bool pair_biased = false;   ///< the pair-only estimate differs beyond its uncertainty
};

/// Without a remote, what the pair can say about a disturbance both sensors see: n from the
/// band's lower and upper halves (the cells split at their median frequency, the final weights
/// kept; each half's covariance as n's own: sandwich raised to the jackknife), compared by the
/// rule of estimate_comparison.hpp at kPairBiasAlpha. One n holds at every frequency of the band;
/// a disturbance whose share of the field's power changes across the band pulls the halves apart
/// (not one whose share is the same at every frequency: the check cannot see that one).
struct BandSplitCheck {
  bool assessed = false;
  double p_value = std::numeric_limits<double>::quiet_NaN();  ///< the smaller of a parameter's (x 9) and the joint
  bool differs = false;   ///< the halves' n differ beyond their uncertainty: the window is not vouched for
  std::string text;       ///< what was found, or why not assessed
  /// The activity split: n of the weighted sections with less field than their median against
  /// n of the others, by the same rule (p as p_value's); NaN when fewer than 8 sections carry weight.
  double activity_p_value = std::numeric_limits<double>::quiet_NaN();
  /// The two splits' spread beyond their noise, added to n's covariance (row-major vec(n), as
  /// n_covariance): per split kHalvesSpreadScale (1 - q / s^2) d d^T with d = vec(n_1 - n_2), the
  /// larger of the joint (s^2 = d^T (V_1 + V_2)^-1 d, q its chi2 95 % point for 9 degrees) and
  /// the largest single entry's (s^2 = d_k^2 / V_kk, q the 95 % point of the largest of 9); zero
  /// where neither exceeds its point, or not assessed.
  Matrix9d spread_covariance = Matrix9d::Zero();
  bool intervals_widened = false;  ///< spread_covariance is not zero
};

/// The share of the halves' outer product d d^T that a spread beyond the noise adds to n's
/// covariance (BandSplitCheck::spread_covariance): the whole estimate may be as far off as the
/// halves are apart.
constexpr double kHalvesSpreadScale = 1.0;

/// How strongly the remote's cells predict the local reference's (see above). m_xx = sum w g
/// Re(x x^H), m_zz = sum w g Re(z z^H), m_zx = sum w g Re(z x^H) (3 x 3, any units);
/// effective_cells = N_eff. Fills coherence, canonical_coherence and strength.
void assess_remote_strength(RemoteReference& remote, const Eigen::Matrix3d& m_xx, const Eigen::Matrix3d& m_zz,
                            const Eigen::Matrix3d& m_zx, double effective_cells);

/// The pair-only estimate n_pair against the remote's n_remote with the covariance of their
/// difference (row-major vec(n), dof `cells`): fills pair_n, difference_*, parameter_z, the
/// p-values and pair_biased, and adds a sentence to text.
void assess_pair_difference(RemoteReference& remote, const Eigen::Matrix3d& n_pair, const Eigen::Matrix3d& n_remote,
                            const Matrix9d& difference_covariance, double cells);

/// Solves A n = C for the instrumental-variable sums (A not symmetric): rows and columns scaled
/// to unit size, LU with partial pivoting. False when A is singular for the precision (no
/// remote signal in some direction). a_inverse: A^-1.
bool instrumental_solve(const Eigen::MatrixXd& a, const Eigen::MatrixXd& c, Eigen::MatrixXd& solution,
                        Eigen::MatrixXd& a_inverse);

}  // namespace magnetometer_insitu_calibration
