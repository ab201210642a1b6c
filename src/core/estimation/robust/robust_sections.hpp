// Internal pieces of the robust estimator (robust_estimator.hpp, steps 3-6): the cells (one
// harmonic of one section), the weighted normal equations with their errors-in-variables
// solve (weighted_eiv_solve.cpp), the IRLS (section_irls.cpp) and the delete-one-section
// jackknife (section_jackknife.cpp). Not installed: src/core only.
#pragma once

#include "magnetometer_insitu_calibration/estimation/fd_wlse.hpp"
#include "magnetometer_insitu_calibration/estimation/remote_reference.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration::detail::robust {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kLn2 = 0.69314718055994531;
constexpr double kCellRejection = 5.0;  // sigmas (d) beyond which a cell gets weight 0
constexpr double kLevelCap = 25.0;      // cap of a cell's d^2 in its section's level
// Fewest weighted sections for which the section jackknife enters the covariance (step 6c);
// below, the jackknife is over kFrequencyGroups interleaved frequency groups instead.
constexpr std::size_t kMinJackknifeSections = 6;
constexpr std::size_t kFrequencyGroups = 8;

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
  const NoiseSpectrum* noise = nullptr;  ///< least squares: the reference noise to correct for (null: none)
  bool remote = false;                   ///< instrumental variables on cell.z
  double sample_period_s = 1.0;
  /// The cell's instruments: the remote's DFT, or the reference's own.
  const Eigen::Vector3cd& instrument(const Cell& cell) const { return remote ? cell.z : cell.x; }
};

/// n from the weighted sums (solve_weighted, solve_frozen): Eq. 2, n = A^-1 C, or, where the
/// reference noise N (nT^2) has power, corrected for it: n = (A - N)^-1 C. ok is false when A
/// is singular; without N, or when A - N is singular, eiv_applied is false and n, a_inverse
/// are Eq. 2's.
struct WeightedSolution {
  bool ok = false;
  bool eiv_applied = false;
  Eigen::Matrix3d n_uncorrected = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d n = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();                      ///< weighted, uncorrected
  Eigen::Matrix3d a_inverse_uncorrected = Eigen::Matrix3d::Zero();  ///< of A
  Eigen::Matrix3d a_inverse = Eigen::Matrix3d::Zero();              ///< of the (corrected) A
  Eigen::Matrix3d noise = Eigen::Matrix3d::Zero();                  ///< N applied, zero if none
};

/// The IRLS: the solution with its last weights, and those weights.
struct IrlsResult : WeightedSolution {
  std::vector<double> weight;          ///< per cell (cell x section)
  std::vector<double> section_weight;
  std::vector<Eigen::Vector3d> scale2; ///< per bin, sigma_l^2
  int iterations = 0;
};

/// Weighted sums of Eq. 2 over the cells (cell weight w times lambda^gamma g; cells of weight 0
/// and of section `exclude` left out, -1 for none): A = sum w g Re(z x^H) and
/// C = sum w g Re(z y^H) with z the instruments (the reference's own x, or the remote's), and
/// with a reference noise to correct for its expected periodogram N = sum w g E|X_noise|^2
/// (nT^2, diagonal; zero without one).
struct NormalEquations {
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d given_noise = Eigen::Matrix3d::Zero();
  bool instrumental = false;  ///< A is sum w g Re(z x^H) of a remote: solved by LU, never corrected
};

/// Delete-one-group jackknife of row-major vec(n) (step 6b): groups are sections, or interleaved
/// frequency groups in windows with too few sections.
struct JackknifeResult {
  Matrix9d covariance = Matrix9d::Constant(kNaN);
  std::size_t sections = 0;  ///< groups that carried weight (sections or frequency groups)
  bool frequency_groups = false;  ///< the groups are interleaved frequency groups
  /// Enough groups with weight (kMinJackknifeSections) and a finite J: it enters the covariance.
  bool usable() const { return sections >= kMinJackknifeSections && covariance.allFinite(); }
};

// weighted_eiv_solve.cpp.
NormalEquations weighted_normal_equations(const std::vector<Cell>& cells, const std::vector<double>& weight,
                                          const Regression& regression);
/// The weighted sums of each group of cells (group[i] in [0, groups); -1: in none), made in one
/// pass, so that a delete-one-group jackknife adds the others' sums instead of summing every
/// cell again per deletion. without(g) equals weighted_normal_equations over the cells outside
/// group g but for the order of the additions (rounding).
class GroupedNormalEquations {
 public:
  GroupedNormalEquations(const std::vector<Cell>& cells, const std::vector<double>& weight,
                         const Regression& regression, const std::vector<int>& group, std::size_t groups);
  NormalEquations without(std::size_t left_out) const;
  /// The sum of the group's cell weights (the IRLS weights, without lambda^gamma): zero for a
  /// group of rejected cells.
  double weight(std::size_t group) const { return weight_[group]; }

 private:
  std::vector<NormalEquations> parts_;
  std::vector<double> weight_;
};
WeightedSolution solve_weighted(const NormalEquations& sums, const Eigen::Matrix3d& noise);
/// n for frozen cell weights: the last step of the IRLS, the band split's halves, the pair-only
/// estimate beside the remote's (the jackknife's refits add GroupedNormalEquations instead).
WeightedSolution solve_frozen(const std::vector<Cell>& cells, const std::vector<double>& weight,
                              const Regression& regression);
/// Step 6d: the covariance of row-major vec(n) that the uncertainty of the noise model's levels
/// (ReferenceNoiseModel::level_covariance) carries through the correction; zero unless the
/// correction was applied.
Matrix9d noise_level_covariance_term(const std::vector<Cell>& cells, const std::vector<double>& weight,
                                     const WeightedSolution& fit, const ReferenceNoiseModel& noise,
                                     double sample_period_s);

/// True when the cells' Huber weights apply: more than one scale bin, so that the scale can
/// follow the residual's colour across the band (section_irls.cpp).
inline bool huber_cell_weights(std::size_t scale_bins) { return scale_bins > 1; }
/// WindowEstimate::weights of the robust estimator with `scale_bins` bins.
inline const char* robust_weights_text(std::size_t scale_bins) {
  return huber_cell_weights(scale_bins) ? "lambda^gamma x Huber cell x section"
                                        : "lambda^gamma x section (one scale bin: no Huber cell weights)";
}

// section_irls.cpp: steps 3 and 5, IRLS over the cells.
IrlsResult irls(const std::vector<Cell>& cells, std::size_t sections, std::size_t bins, const RobustSettings& rs,
                const Regression& regression);

// section_jackknife.cpp: step 6b and 6c.
JackknifeResult section_jackknife(const std::vector<Cell>& cells, const std::vector<double>& weight,
                                  std::size_t k_sections, const Regression& regression);
/// Delete-one-group jackknife over `groups` interleaved frequency groups (the cells in frequency
/// order, every groups-th in one group), n refitted without each group with the same weights
/// (step 6b for windows of fewer than kMinJackknifeSections weighted sections).
JackknifeResult frequency_group_jackknife(const std::vector<Cell>& cells, const std::vector<double>& weight,
                                          std::size_t groups, const Regression& regression);
/// The jackknife's groups of the cells (for GroupedNormalEquations): each cell's section, or its
/// interleaved frequency group (the cells in frequency order, every groups-th in one group).
std::vector<int> section_groups(const std::vector<Cell>& cells);
std::vector<int> interleaved_frequency_groups(const std::vector<Cell>& cells, std::size_t groups);
Matrix9d combine_covariances(const Matrix9d& sandwich, const JackknifeResult& jack);
/// J = (G-1)/G sum (v_g - mean)(v_g - mean)^T of leave-one-group-out values of row-major vec(n).
JackknifeResult jackknife_statistic(const std::vector<Eigen::Matrix<double, 9, 1>>& leave_out);

/// Step 6 over the final weighted cells: the reported covariance of row-major vec(n) and its
/// parts, and the window's quality figures.
struct CellCovariance {
  Matrix9d covariance = Matrix9d::Zero();  ///< reported: 6c, plus 6d
  Matrix9d sandwich = Matrix9d::Zero();    ///< 6a
  JackknifeResult jackknife;               ///< 6b
  Matrix9d level_term = Matrix9d::Zero();  ///< 6d
  double cells = 0.0;                      ///< the cells the sandwich rests on (WindowEstimate::covariance_dof)
  std::string intervals;                   ///< WindowEstimate::intervals
  Eigen::Vector3d coherence = Eigen::Vector3d::Zero();        ///< 1 - weighted residual power / test power
  Eigen::Vector3d residual_rms_nT = Eigen::Vector3d::Zero();  ///< in-band rms of the residual, nT
  double downweighted_fraction = 0.0;      ///< share of cell weight removed by the M-step
};
/// robust_covariance.cpp. `noise`: the model n was corrected with (null: none).
CellCovariance cell_covariance(const std::vector<Cell>& cells, const IrlsResult& fit, std::size_t k_sections,
                               std::size_t bins, const ReferenceNoiseModel* noise, const Regression& regression);

// remote_cells.cpp: the remote's strength over the weighted cells, and the pair-only estimate on
// the same cells and weights against the remote's (remote_reference.hpp).
/// coherence, canonical coherence and first-stage F of the remote over the cells and weights.
void assess_cells_remote_strength(RemoteReference& remote, const std::vector<Cell>& cells,
                                  const std::vector<double>& weight);
/// The band-split check (remote_reference.hpp) over the cells with the fit's final weights.
BandSplitCheck band_split_check(const std::vector<Cell>& cells, const IrlsResult& fit, std::size_t k_sections,
                                std::size_t bins, const ReferenceNoiseModel* noise, const Regression& regression);
/// The pair-only estimate (least squares with `pair`'s noise correction) with the remote fit's
/// final weights, the covariance of its difference from the remote's n (per-cell influence
/// difference, raised to the jackknife of the difference over the same groups, plus the
/// correction's noise-level term when `noise` corrected the pair: the remote's n has no
/// correction, so a level error moves the difference in every cell alike) and the test.
void assess_cells_pair_difference(RemoteReference& remote, const std::vector<Cell>& cells, const IrlsResult& fit,
                                  std::size_t k_sections, const Regression& pair, const Regression& iv,
                                  const ReferenceNoiseModel* noise, double covariance_cells);

}  // namespace magnetometer_insitu_calibration::detail::robust
