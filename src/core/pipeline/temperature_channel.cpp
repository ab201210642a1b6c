// Which auxiliary channel is the test's sensor temperature, and its values on the grid.
#include "magnetometer_insitu_calibration/pipeline/temperature_channel.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>

namespace magnetometer_insitu_calibration {

namespace {

std::string lower(const std::string& text) {
  std::string out;
  for (char c : text) out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

bool is_celsius(const std::string& unit) {
  const std::string u = lower(unit);
  return u == "degc" || u == "deg_c" || u == "deg c" || u == "c" || u == "\xc2\xb0" "c" || u == "celsius";
}

const AuxiliaryChannel* checked(const VectorRecord& record, const AuxiliaryChannel* channel) {
  if (channel != nullptr && channel->values.size() != record.size()) {
    throw InputError(record.source, "auxiliary channel " + channel->name + " has " + std::to_string(channel->values.size()) +
                                        " values for " + std::to_string(record.size()) + " samples");
  }
  return channel;
}

}  // namespace

const AuxiliaryChannel* find_temperature_channel(const VectorRecord& record, const std::string& name) {
  if (name == "none") return nullptr;
  const auto& aux = record.auxiliary;
  if (name != "auto") {
    for (const AuxiliaryChannel& a : aux) {
      if (a.name == name) return checked(record, &a);
    }
    std::string have;
    for (const AuxiliaryChannel& a : aux) have += (have.empty() ? "" : ", ") + a.name;
    throw InputError(record.source, "no auxiliary channel '" + name + "' for the temperature (the record has: " +
                                        (have.empty() ? std::string("none") : have) + ")");
  }
  for (const AuxiliaryChannel& a : aux) {
    if (a.name == "sensor_temperature") return checked(record, &a);
  }
  for (const AuxiliaryChannel& a : aux) {
    if (lower(a.description).find("sensor") != std::string::npos && is_celsius(a.unit)) return checked(record, &a);
  }
  for (const AuxiliaryChannel& a : aux) {
    if (lower(a.name) == "temperature") return checked(record, &a);
  }
  return nullptr;
}

Eigen::VectorXd interpolate_channel(const std::vector<double>& time_s, const std::vector<double>& values,
                                    const std::vector<double>& at, double max_gap_s, ChannelInterpolation how) {
  std::vector<double> t, v;  // finite samples only
  for (std::size_t i = 0; i < time_s.size() && i < values.size(); ++i) {
    if (std::isfinite(values[i])) {
      t.push_back(time_s[i]);
      v.push_back(values[i]);
    }
  }
  Eigen::VectorXd out = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(at.size()), std::numeric_limits<double>::quiet_NaN());
  const std::size_t n = t.size();
  if (n == 0) return out;
  const auto near = [&](std::size_t a, std::size_t b) { return t[b] - t[a] <= max_gap_s; };
  std::size_t k = 0;  // at is increasing: walk once
  for (std::size_t i = 0; i < at.size(); ++i) {
    const double x = at[i];
    if (x < t.front() || x > t.back()) continue;
    while (k + 1 < n && t[k + 1] < x) ++k;
    if (t[k] == x || k + 1 == n) {
      if (t[k] == x) out(static_cast<Eigen::Index>(i)) = v[k];
      continue;
    }
    if (!near(k, k + 1)) continue;
    const double h = t[k + 1] - t[k], u = (x - t[k]) / h;
    if (how == ChannelInterpolation::kLinear || k == 0 || k + 2 >= n || !near(k - 1, k) || !near(k + 1, k + 2)) {
      out(static_cast<Eigen::Index>(i)) = v[k] + u * (v[k + 1] - v[k]);
      continue;
    }
    const double m0 = (v[k + 1] - v[k - 1]) / (t[k + 1] - t[k - 1]);
    const double m1 = (v[k + 2] - v[k]) / (t[k + 2] - t[k]);
    const double u2 = u * u, u3 = u2 * u;
    out(static_cast<Eigen::Index>(i)) = (2 * u3 - 3 * u2 + 1) * v[k] + (u3 - 2 * u2 + u) * h * m0 +
                                        (-2 * u3 + 3 * u2) * v[k + 1] + (u3 - u2) * h * m1;
  }
  return out;
}

}  // namespace magnetometer_insitu_calibration
