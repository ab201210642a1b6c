// The reference's scale along the main field from a scalar magnetometer: see scalar_check.hpp.
#include "magnetometer_insitu_calibration/estimation/scalar_check.hpp"

#include "magnetometer_insitu_calibration/estimation/sampling_distributions.hpp"

#include <Eigen/LU>

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace magnetometer_insitu_calibration {

namespace {

constexpr double kDegree = M_PI / 180.0;

/// sqrt(g^T S g) for a gradient g.
double spread(const Eigen::Vector3d& g, const Eigen::Matrix3d& s) { return std::sqrt(std::max(0.0, g.dot(s * g))); }

}  // namespace

FieldDirection parse_field_direction(const std::string& text) {
  const std::string expected = "expected D,I or D,I,hdz in degrees (|I| <= 90), got '" + text + "'";
  const auto comma = text.find(',');
  if (comma == std::string::npos) throw std::invalid_argument(expected);
  const std::string rest = text.substr(comma + 1);
  const auto second = rest.find(',');
  FieldDirection d;
  d.hdz = second != std::string::npos && rest.substr(second + 1) == "hdz";
  if (second != std::string::npos && !d.hdz) throw std::invalid_argument(expected);
  const auto number = [&](const std::string& field) {
    std::size_t used = 0;
    double value = std::numeric_limits<double>::quiet_NaN();
    try {
      value = std::stod(field, &used);
    } catch (const std::exception&) {
      throw std::invalid_argument(expected);
    }
    if (used != field.size() || !std::isfinite(value)) throw std::invalid_argument(expected);
    return value;
  };
  d.declination_deg = number(text.substr(0, comma));
  d.inclination_deg = number(rest.substr(0, second));
  if (!(std::abs(d.inclination_deg) <= 90.0)) throw std::invalid_argument(expected);
  return d;
}

Eigen::Vector3d FieldDirection::unit() const {
  const double d = declination_deg * kDegree, i = inclination_deg * kDegree;
  return hdz ? Eigen::Vector3d(std::cos(i), 0.0, std::sin(i))
             : Eigen::Vector3d(std::cos(i) * std::cos(d), std::cos(i) * std::sin(d), std::sin(i));
}

ScalarCheck assess_scalar(const Eigen::Vector3d& c, const Eigen::Matrix3d& covariance, double cells,
                          const Eigen::Matrix3d& n, const Matrix9d& n_covariance,
                          const std::optional<FieldDirection>& given) {
  ScalarCheck out;
  out.coefficients = c;
  out.coefficients_covariance = covariance;
  out.cells = cells;
  const double norm = c.norm();
  if (!(norm > 0.0) || !covariance.allFinite()) {
    out.text = "scalar check not assessed: no finite fit of F on the reference";
    return out;
  }
  const double q = student_t_two_sided_quantile(0.05, cells > 0.0 ? cells : std::numeric_limits<double>::infinity());
  const Eigen::Vector3d u = c / norm;
  out.assessed = true;
  // k = 1 / |c|: dk/dc = -u / |c|^2.
  out.reference_scale = 1.0 / norm;
  out.reference_scale_ci95 = q * spread(u, covariance) / (norm * norm);
  // Direction cosines u = c / |c|: du/dc = (I - u u^T) / |c|.
  const Eigen::Matrix3d j = (Eigen::Matrix3d::Identity() - u * u.transpose()) / norm;
  const Eigen::Matrix3d u_cov = j * covariance * j.transpose();
  out.direction_cosines = u;
  out.direction_cosines_ci95 = q * u_cov.diagonal().cwiseMax(0.0).cwiseSqrt();
  if (given) {
    const Eigen::Vector3d b = given->unit();
    for (int l = 0; l < 3; ++l) {
      if (std::abs(b(l)) < 0.2) continue;  // an axis across the field: its scale is not determined
      out.axis_scale(l) = b(l) / c(l);
      out.axis_scale_ci95(l) = q * std::abs(b(l)) * std::sqrt(std::max(0.0, covariance(l, l))) / (c(l) * c(l));
    }
    const double cosine = std::clamp(u.dot(b), -1.0, 1.0);
    out.direction_offset_deg = std::acos(cosine) / kDegree;
    // Small angles: the offset's spread is that of u across b.
    const Eigen::Vector3d across = (u - cosine * b).normalized();
    out.direction_offset_ci95_deg = q * spread(across, u_cov) / kDegree;
  }
  // The test: c_T = n^-1 c; its scale 1 / |c_T|, c's and n's uncertainty added.
  const Eigen::Matrix3d n_inverse = n.inverse();
  const Eigen::Vector3d c_test = n_inverse * c;
  const double test_norm = c_test.norm();
  if (test_norm > 0.0 && n_covariance.allFinite()) {
    const Eigen::Vector3d v = c_test / test_norm;
    const Eigen::RowVector3d g_c = -(v.transpose() * n_inverse) / (test_norm * test_norm);
    // d(n^-1 c) / dn_kl = -n^-1 E_kl n^-1 c: entry (row i) is -(n^-1)_ik c_T,l.
    Eigen::Matrix<double, 1, 9> g_n;
    for (int k = 0; k < 3; ++k)
      for (int l = 0; l < 3; ++l) g_n(3 * k + l) = v.dot(-n_inverse.col(k) * c_test(l)) * (-1.0 / (test_norm * test_norm));
    const double variance = (g_c * covariance * g_c.transpose()).value() + (g_n * n_covariance * g_n.transpose()).value();
    out.test_scale = 1.0 / test_norm;
    out.test_scale_ci95 = q * std::sqrt(std::max(0.0, variance));
  }
  out.reference_off = std::abs(out.reference_scale - 1.0) > out.reference_scale_ci95;
  char text[256];
  std::snprintf(text, sizeof text, "reference scale along the field %.5f +- %.5f%s; test %.5f +- %.5f",
                out.reference_scale, out.reference_scale_ci95,
                out.reference_off ? " (departs from 1: the reference needs calibration)" : "", out.test_scale,
                out.test_scale_ci95);
  out.text = text;
  if (given) {  // each axis's scale where the given direction determines it, and the direction's fit
    for (int l = 0; l < 3; ++l) {
      if (!std::isfinite(out.axis_scale(l))) continue;
      std::snprintf(text, sizeof text, "; reference scale %c %.5f +- %.5f", "xyz"[l], out.axis_scale(l),
                    out.axis_scale_ci95(l));
      out.text += text;
    }
    std::snprintf(text, sizeof text, "; fitted direction %.3f +- %.3f deg from the given one",
                  out.direction_offset_deg, out.direction_offset_ci95_deg);
    out.text += text;
  }
  return out;
}

}  // namespace magnetometer_insitu_calibration
