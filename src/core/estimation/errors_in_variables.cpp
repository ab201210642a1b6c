// Errors-in-variables correction: see errors_in_variables.hpp for the reasoning.
#include "magnetometer_insitu_calibration/estimation/errors_in_variables.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <cmath>
#include <cstdio>
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

const char* noise_source_name(NoiseSource source) {
  switch (source) {
    case NoiseSource::kNone: return "none";
    case NoiseSource::kMakerFigure: return "maker's figure";
    case NoiseSource::kThreeCorneredHat: return "three-cornered hat";
    case NoiseSource::kPairAboveBand: return "pair above the band";
  }
  return "unknown";
}

bool ReferenceNoiseModel::has_noise() const {
  return source != NoiseSource::kNone && spectrum.any();
}

bool NoiseSpectrum::any() const {
  return (white_nT.array() > 0.0).any() || (pink_nT_per_sqrt_hz.array() > 0.0).any();
}

NoiseSpectrum NoiseSpectrum::fluxgate_figure(double figure_pT) {
  NoiseSpectrum s;
  s.pink_nT_per_sqrt_hz.setConstant(figure_pT / 1000.0);
  return s;
}

ReferenceNoiseModel ReferenceNoiseModel::maker_figure(const NoiseSpectrum& figure) {
  ReferenceNoiseModel model;
  if (!figure.any()) return model;
  model.source = NoiseSource::kMakerFigure;
  model.spectrum = figure;
  return model;
}

void ReferenceNoiseModel::validate() const {
  const auto levels_ok = [](const Eigen::Vector3d& v) { return v.allFinite() && (v.array() >= 0.0).all(); };
  if (!levels_ok(spectrum.white_nT) || !levels_ok(spectrum.pink_nT_per_sqrt_hz))
    throw InputError("reference noise", "levels must be finite and >= 0");
  for (const Eigen::Matrix2d& c : level_covariance) {
    if (!c.allFinite() || c(0, 0) < 0.0 || c(1, 1) < 0.0 ||
        std::abs(c(0, 1) - c(1, 0)) > 1e-12 * c.cwiseAbs().maxCoeff() ||
        c(0, 1) * c(0, 1) > c(0, 0) * c(1, 1) * (1.0 + 1e-9))
      throw InputError("reference noise", "level covariance must be a finite symmetric positive semi-definite 2 x 2 per axis");
  }
}

const char* errors_in_variables_name(ErrorsInVariables applied) {
  switch (applied) {
    case ErrorsInVariables::kNotApplicable: return "not_applicable";
    case ErrorsInVariables::kOff: return "off";
    case ErrorsInVariables::kNoNoiseModel: return "no_noise_model";
    case ErrorsInVariables::kRefused: return "refused";
    case ErrorsInVariables::kApplied: return "applied";
    case ErrorsInVariables::kRemoteReference: return "remote_reference";
  }
  return "unknown";
}

std::string errors_in_variables_text(ErrorsInVariables applied, const ReferenceNoiseModel& noise) {
  std::string source = noise_source_name(noise.source);
  if (!noise.provider.empty()) source += " with " + noise.provider;
  switch (applied) {
    case ErrorsInVariables::kNotApplicable: return "none (plain Eq. 2)";
    case ErrorsInVariables::kOff: return "none (off)";
    case ErrorsInVariables::kNoNoiseModel: return "none (no reference noise model)";
    case ErrorsInVariables::kRefused: return "none (the reference noise from the " + source + " is as large as the signal: refused)";
    case ErrorsInVariables::kRemoteReference: return "none needed (remote reference)";
    case ErrorsInVariables::kApplied: break;
  }
  const Eigen::Vector3d white = 1e3 * noise.spectrum.white_nT, pink = 1e3 * noise.spectrum.pink_nT_per_sqrt_hz;
  char text[256];
  std::snprintf(text, sizeof text,
                "reference noise from the %s: white %.3g/%.3g/%.3g pT rms, 1/f %.3g/%.3g/%.3g pT/sqrt(Hz) at 1 Hz (x/y/z)",
                source.c_str(), white(0), white(1), white(2), pink(0), pink(1), pink(2));
  return text;
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
