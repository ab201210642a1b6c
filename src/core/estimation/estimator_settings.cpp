// Names, parsing and validation of the estimator settings (estimator_settings.hpp), and the
// band's harmonics in a window.
#include "magnetometer_insitu_calibration/estimation/estimator_settings.hpp"

#include "magnetometer_insitu_calibration/estimation/band_selection.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

namespace magnetometer_insitu_calibration {

const char* estimator_method_name(EstimatorMethod method) {
  return method == EstimatorMethod::kPlain ? "plain" : "robust";
}

EstimatorMethod parse_estimator_method(const std::string& text, const std::string& where) {
  if (text == "plain") return EstimatorMethod::kPlain;
  if (text == "robust") return EstimatorMethod::kRobust;
  throw InputError(where, "expected plain or robust, got '" + text + "'");
}

void RobustSettings::validate() const {
  auto positive = [](double v) { return v > 0.0 && std::isfinite(v); };
  if (!positive(screen_threshold)) throw InputError("screen_threshold", "must be a positive number of sigmas");
  if (!positive(screen_baseline_s)) throw InputError("screen_baseline_s", "must be a positive time in s");
  if (!(screen_margin_s >= 0.0) || !std::isfinite(screen_margin_s))
    throw InputError("screen_margin_s", "must be a time >= 0 s");
  if (!positive(section_s)) throw InputError("section_s", "must be a positive time in s");
  if (!positive(huber_k)) throw InputError("huber_k", "must be positive (sigma units)");
  if (!(section_rejection > 2.0) || !std::isfinite(section_rejection))
    throw InputError("section_rejection", "must be finite and above 2");
  if (iterations < 1 || iterations > 100) throw InputError("iterations", "must be in [1, 100]");
  BandSelectionSettings band;
  band.search_low_hz = band_search_low_hz;
  band.search_high_hz = band_search_high_hz;
  band.min_coherence = min_band_coherence;
  band.validate();
  if (!positive(delay_max_hz)) throw InputError("delay_max_hz", "must be a positive frequency in Hz");
}

double EstimatorSettings::band_harmonics(double window_s) const {
  return std::max(0.0, std::floor(band_high_hz * window_s) - std::ceil(band_low_hz * window_s) + 1.0);
}

void EstimatorSettings::validate() const {
  auto fail = [](const std::string& field, const std::string& problem) {
    throw InputError(field, problem);
  };
  if (!(band_low_hz > 0.0) || !std::isfinite(band_low_hz))
    fail("band_low_hz", "must be a positive frequency in Hz (harmonic 0 is the mean)");
  if (!(band_high_hz > band_low_hz) || !std::isfinite(band_high_hz))
    fail("band_high_hz", "must be finite and above band_low_hz (empty band)");
  if (!std::isfinite(gamma) || gamma < 0.0 || gamma > 4.0) fail("gamma", "must be in [0, 4]");
  if (min_harmonics < 5) fail("min_harmonics", "must be at least 5");
  if (!(max_condition_number > 1.0)) fail("max_condition_number", "must be above 1");
  if (!(min_coherence >= 0.0 && min_coherence < 1.0)) fail("min_coherence", "must be in [0, 1)");
  robust.validate();
}

double EstimatorSettings::harmonics_window_s() const {
  // floor(U w) - ceil(L w) + 1 >= (U - L) w - 1: M harmonics for every w >= (M + 1) / (U - L).
  return std::ceil((static_cast<double>(min_harmonics) + 1.0) / (band_high_hz - band_low_hz));
}

std::string EstimatorSettings::too_few_harmonics(double window_s) const {
  const double harmonics = band_harmonics(window_s);
  if (harmonics >= static_cast<double>(min_harmonics)) return {};
  std::ostringstream text;
  text << "holds only " << harmonics << " DFT harmonics in the band " << band_low_hz << "-" << band_high_hz
       << " Hz, fewer than the " << min_harmonics << " a window needs (every window would be flagged); windows of "
       << harmonics_window_s() << " s or longer hold them";
  return text.str();
}

std::string EstimatorSettings::band_above_nyquist(double period_s) const {
  const double nyquist_hz = 0.5 / period_s;
  if (!(band_high_hz > nyquist_hz)) return {};
  std::ostringstream text;
  text << "the band's top " << band_high_hz << " Hz is above the Nyquist frequency " << nyquist_hz << " Hz of the "
       << period_s << " s estimation period: give a band below it (for example " << band_low_hz << "-"
       << 0.5 * nyquist_hz << " Hz)";
  return text.str();
}

}  // namespace magnetometer_insitu_calibration
