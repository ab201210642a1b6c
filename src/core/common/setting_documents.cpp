// YAML blocks and Markdown tables printed from the setting declarations (setting_documents.hpp).
#include "magnetometer_insitu_calibration/common/setting_documents.hpp"

#include <sstream>
#include <stdexcept>

namespace magnetometer_insitu_calibration {

namespace {

/// "[s, > 0]", "[robust|plain]", "[bool]", "[topic]".
std::string yaml_bracket(const SettingDeclaration& d) {
  std::string what;
  switch (d.kind) {
    case SettingKind::kFlag: what = "bool"; break;
    case SettingKind::kTopic: what = "topic"; break;
    case SettingKind::kPath: what = "path"; break;
    case SettingKind::kList: what = "list"; break;
    case SettingKind::kText: what = "text"; break;
    case SettingKind::kChoice:
      for (const std::string& c : d.choices) what += (what.empty() ? "" : "|") + c;
      break;
    default: {
      what = d.unit.empty() ? "-" : d.unit;
      const std::string range = d.range.text();
      if (!range.empty()) what += ", " + range;
    }
  }
  return "[" + what + "]";
}

bool set_in_yaml(const SettingDeclaration& d) {
  const bool plain_kind = d.kind == SettingKind::kNumber || d.kind == SettingKind::kInteger ||
                          d.kind == SettingKind::kFlag || d.kind == SettingKind::kChoice;
  return plain_kind && d.default_note.empty() && !d.required;
}

std::string cell(std::string text) {
  for (std::size_t at = text.find('|'); at != std::string::npos; at = text.find('|', at + 2)) text.replace(at, 1, "\\|");
  return text;
}

std::string range_cell(const SettingDeclaration& d) {
  if (d.kind == SettingKind::kChoice) {
    std::string names;
    for (const std::string& c : d.choices) names += (names.empty() ? "" : ", ") + c;
    return names;
  }
  return d.range.text();
}

std::string unit_cell(const SettingDeclaration& d) {
  switch (d.kind) {
    case SettingKind::kFlag: return "bool";
    case SettingKind::kTopic: return "topic";
    case SettingKind::kPath: return "path";
    case SettingKind::kList: return "list";
    case SettingKind::kText: return "text";
    case SettingKind::kChoice: return "choice";
    default: return d.unit.empty() ? "-" : d.unit;
  }
}

std::pair<std::string, std::string> markers(const std::string& name, BlockStyle style) {
  if (style == BlockStyle::kYaml) return {"# <settings " + name + ">\n", "# </settings>\n"};
  return {"<!-- settings " + name + " -->\n", "<!-- /settings -->\n"};
}

}  // namespace

std::string settings_yaml(const SettingDeclarations& declarations) {
  std::ostringstream out;
  std::string group;
  for (const SettingDeclaration& d : declarations) {
    if (d.parameter.empty()) continue;
    if (d.group != group) {
      group = d.group;
      out << "\n# --- " << group << "\n";
    }
    std::string value = d.default_text();
    if (d.kind == SettingKind::kChoice || d.kind == SettingKind::kFlag) value = setting_value_text(d.default_value);
    // A real number reads as one in YAML (rosparam would load "1" as an integer).
    if (d.kind == SettingKind::kNumber && set_in_yaml(d) && value.find_first_of(".en") == std::string::npos) value += ".0";
    const std::string line = (set_in_yaml(d) ? "" : "# ") + d.parameter + ": " + value;
    out << line << std::string(line.size() < 34 ? 34 - line.size() : 1, ' ') << "# " << yaml_bracket(d) << " "
        << d.help << "\n";
  }
  return out.str();
}

std::string parameter_table(const SettingDeclarations& declarations) {
  std::ostringstream out;
  out << "| parameter | unit | default | range | meaning |\n|---|---|---|---|---|\n";
  for (const SettingDeclaration& d : declarations) {
    if (d.parameter.empty()) continue;
    out << "| `" << d.parameter << "` | " << cell(unit_cell(d)) << " | " << cell(d.default_text()) << " | "
        << cell(range_cell(d)) << " | " << cell(d.help) << " |\n";
  }
  return out.str();
}

std::string option_table(const SettingDeclarations& declarations) {
  std::ostringstream out;
  out << "| option | unit | default | range | meaning |\n|---|---|---|---|---|\n";
  for (std::size_t i = 0; i < declarations.size(); ++i) {
    const SettingDeclaration& d = declarations[i];
    if (d.option.empty()) continue;
    bool second = false;  // the HIGH of a LOW:HIGH option, printed with its LOW
    for (std::size_t j = 0; j < i; ++j) second = second || declarations[j].option == d.option;
    if (second) continue;
    const SettingDeclaration* high = nullptr;
    for (std::size_t j = i + 1; j < declarations.size(); ++j)
      if (declarations[j].option == d.option) high = &declarations[j];
    std::string name = "`" + d.option + "`";
    if (d.kind == SettingKind::kFlag) name += ", `--no-" + d.option.substr(2) + "`";
    if (high != nullptr) {
      out << "| `" << d.option << " LOW:HIGH` | " << cell(unit_cell(d)) << " | " << d.option_default_text() << ":"
          << high->option_default_text() << " | " << cell(d.range.text()) << " | " << cell(d.help + "; " + high->help)
          << " |\n";
      continue;
    }
    out << "| " << name << " | " << cell(unit_cell(d)) << " | " << cell(d.option_default_text()) << " | "
        << cell(range_cell(d)) << " | " << cell(d.help) << " |\n";
  }
  return out.str();
}

std::string marked_block(const std::string& document, const std::string& name, BlockStyle style) {
  const auto [begin, end] = markers(name, style);
  const std::size_t from = document.find(begin);
  const std::size_t to = from == std::string::npos ? from : document.find(end, from);
  if (to == std::string::npos) throw std::runtime_error("no block '" + begin.substr(0, begin.size() - 1) + "'");
  return document.substr(from + begin.size(), to - from - begin.size());
}

std::string with_marked_block(const std::string& document, const std::string& name, BlockStyle style,
                              const std::string& block) {
  const auto [begin, end] = markers(name, style);
  const std::size_t from = document.find(begin);
  const std::size_t to = from == std::string::npos ? from : document.find(end, from);
  if (to == std::string::npos) throw std::runtime_error("no block '" + begin.substr(0, begin.size() - 1) + "'");
  return document.substr(0, from + begin.size()) + block + document.substr(to);
}

}  // namespace magnetometer_insitu_calibration
