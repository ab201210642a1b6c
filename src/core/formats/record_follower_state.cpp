// The record follower's state file; see record_follower.hpp.
#include "magnetometer_insitu_calibration/formats/record_follower.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <type_traits>
#include <vector>
#include <fstream>
#include <sstream>

namespace magnetometer_insitu_calibration {

namespace {

/// `text` as a double-quoted YAML scalar.
std::string quoted(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

std::string number_text(double value) {
  if (std::isinf(value)) return value < 0 ? "-.inf" : ".inf";
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.17g", value);
  return buffer;
}

}  // namespace

std::string follower_state_text(const RecordFollowerState& state) {
  std::ostringstream out;
  out << "# record_file_follower: the newest sample published (UNIX s); after a restart the samples after it\n"
      << "newest_published: " << number_text(state.newest_s)
      << (std::isfinite(state.newest_s) ? "  # " + time_for_message(state.newest_s) : std::string("  # none yet")) << "\n"
      << "station: " << quoted(state.station) << "\n"
      << "sample_period: " << number_text(state.sample_period_s) << "  # s; 0 = not known yet\n"
      << "components: [" << quoted(state.components[0]) << ", " << quoted(state.components[1]) << ", "
      << quoted(state.components[2]) << "]\n"
      << "path: " << quoted(state.path) << "\n";
  return out.str();
}

RecordFollowerState parse_follower_state(const std::string& text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(source, std::string("not YAML: ") + e.what());
  }
  if (!root.IsMap()) throw InputError(source, "not a state file (no keys)");
  RecordFollowerState state;
  const auto field = [&](const char* key, auto& value, bool required) {
    const YAML::Node node = root[key];
    if (!node) {
      if (required) throw InputError(source, std::string(key) + ": missing");
      return;
    }
    try {
      value = node.as<std::decay_t<decltype(value)>>();
    } catch (const YAML::Exception&) {
      throw InputError(source, std::string(key) + ": malformed");
    }
  };
  field("newest_published", state.newest_s, true);
  field("station", state.station, false);
  field("sample_period", state.sample_period_s, false);
  std::vector<std::string> components;
  field("components", components, false);
  if (!components.empty() && components.size() != 3) throw InputError(source, "components: expected three names");
  for (std::size_t i = 0; i < components.size(); ++i) state.components[i] = components[i];
  field("path", state.path, false);
  if (std::isnan(state.newest_s) || state.newest_s == std::numeric_limits<double>::infinity()) {
    throw InputError(source, "newest_published: not a time");
  }
  if (!(state.sample_period_s >= 0.0) || !std::isfinite(state.sample_period_s)) {
    throw InputError(source, "sample_period: must be >= 0 s");
  }
  return state;
}

RecordFollowerState read_follower_state(const std::string& path) {
  std::error_code error;
  if (!std::filesystem::exists(path, error) && !error) return RecordFollowerState();
  std::ifstream in(path);
  if (!in) throw InputError(path, "cannot read the state file");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_follower_state(text.str(), path);
}

}  // namespace magnetometer_insitu_calibration
