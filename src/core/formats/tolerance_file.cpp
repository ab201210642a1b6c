// The tolerance file: see tolerance_file.hpp.
#include "magnetometer_insitu_calibration/formats/tolerance_file.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <utility>

namespace magnetometer_insitu_calibration {

namespace {

/// One value (all three entries) or a list of three; each a positive finite number.
Eigen::Vector3d three_values(const YAML::Node& node, const std::string& where) {
  const auto number = [&](const YAML::Node& n) {
    double v = 0.0;
    try {
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      throw InputError(where, "expected a number, got '" + (n.IsScalar() ? n.Scalar() : std::string("a list or map")) + "'");
    }
    if (!(v > 0.0) || !std::isfinite(v)) throw InputError(where, "must be a positive finite tolerance, got " + n.Scalar());
    return v;
  };
  if (node.IsScalar()) return Eigen::Vector3d::Constant(number(node));
  if (!node.IsSequence() || node.size() != 3) throw InputError(where, "expected one number or a list of three");
  return Eigen::Vector3d(number(node[0]), number(node[1]), number(node[2]));
}

}  // namespace

Tolerances parse_tolerances(const std::string& text, const std::string& name) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(name + ":" + std::to_string(e.mark.line + 1), std::string("not YAML: ") + e.msg);
  }
  Tolerances t;
  // An empty file would silently be INTERMAGNET's standard under the file's name.
  if (root.IsNull()) {
    throw InputError(name, "holds none of scale_percent, nonorthogonality_deg, misalignment_deg (for INTERMAGNET's "
                           "1-second standard give no tolerance file)");
  }
  if (!root.IsMap()) throw InputError(name, "expected keys scale_percent, nonorthogonality_deg, misalignment_deg");
  bool scale = false, nonorthogonality = false, misalignment = false;
  std::map<std::string, int> key_lines;  // 1-based line of each key given
  for (const auto& entry : root) {
    const std::string key = entry.first.as<std::string>();
    const int line = entry.first.Mark().line + 1;
    // YAML allows no key twice; yaml-cpp reads both, and the later would silently win.
    if (const auto first = key_lines.find(key); first != key_lines.end()) {
      throw InputError(name + ":" + std::to_string(line), "key '" + key + "' given twice (first on line " +
                                                              std::to_string(first->second) + ")");
    }
    key_lines[key] = line;
    const std::string where = name + ": " + key;
    if (key == "scale_percent") {
      t.scale = three_values(entry.second, where) / 100.0;
      scale = true;
    } else if (key == "nonorthogonality_deg") {
      t.nonorthogonality_deg = three_values(entry.second, where);
      nonorthogonality = true;
    } else if (key == "misalignment_deg") {
      t.misalignment_deg = three_values(entry.second, where);
      misalignment = true;
    } else {
      throw InputError(where, "unknown key (expected scale_percent, nonorthogonality_deg, misalignment_deg)");
    }
  }
  // The report says which tolerances are the file's and which the standard's.
  std::string left_out;
  for (const auto& [given, key] : {std::pair{scale, "scale_percent"}, std::pair{nonorthogonality, "nonorthogonality_deg"},
                                   std::pair{misalignment, "misalignment_deg"}}) {
    if (!given) left_out += std::string(left_out.empty() ? "" : ", ") + key;
  }
  t.source = left_out.empty() ? name : name + "; " + left_out + " not in it: INTERMAGNET's 1-second standard";
  return t;
}

Tolerances read_tolerance_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "cannot open the tolerance file");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_tolerances(text.str(), path);
}

}  // namespace magnetometer_insitu_calibration
