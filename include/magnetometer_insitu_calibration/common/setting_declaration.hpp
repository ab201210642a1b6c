// One declaration per user setting: its key, how each front end spells it (the node's private ROS
// parameter, calibrate_records' option), its unit, default, allowed range and one line of help.
// The node loaders, the command-line options, the names in error messages, config/*.yaml and the
// parameter tables of docs/nodes.md and docs/programs.md all come from these declarations
// (setting_bindings.hpp binds a key to the field it sets; print_settings writes the documents;
// test_setting_documents fails when a document differs).
#pragma once

#include <limits>
#include <string>
#include <variant>
#include <vector>

namespace magnetometer_insitu_calibration {

enum class SettingKind {
  kNumber,   ///< a finite real number in its unit
  kInteger,  ///< a whole number
  kFlag,     ///< true or false
  kChoice,   ///< one of `choices`
  kText,     ///< free text (a name, a label, "D,I")
  kTopic,    ///< a ROS graph name (the node checks it)
  kPath,     ///< a file name
  kList,     ///< a structured value (the node's ~tests list), read by its front end's own code
};

/// A value as a front end reads it: kNumber double, kInteger long long, kFlag bool, the text
/// kinds std::string; kList holds its text description.
using SettingValue = std::variant<double, long long, bool, std::string>;

/// Bounds of a number or integer: [low, high], either end open (excluded) or absent (infinite).
struct SettingRange {
  double low = -std::numeric_limits<double>::infinity();
  double high = std::numeric_limits<double>::infinity();
  bool low_open = false, high_open = false;

  /// "> 0", "[0, 1]", "[1, 100]", "> 2", "" for any finite value.
  std::string text() const;
  bool holds(double value) const;
};
SettingRange above(double low);           ///< (low, inf)
SettingRange at_least(double low);        ///< [low, inf)
SettingRange between(double low, double high);  ///< [low, high]

struct SettingDeclaration {
  std::string key;        ///< the core's field name, as its checks name it (InputError::where)
  /// Other names the core's checks give the same value (a stage's own settings struct).
  std::vector<std::string> core_aliases;
  std::string parameter;  ///< private ROS parameter of the node, "" = not a parameter
  std::string option;     ///< command-line option ("--gamma"), "" = not an option
  SettingKind kind = SettingKind::kNumber;
  std::string unit;       ///< "s", "Hz", "nT", "sigmas", "-" (a ratio or count), "" for flags and text
  SettingValue default_value;
  /// When the default is not a plain value: what it is ("input_period", "none: the whole
  /// record"); the field's own default then stands for it.
  std::string default_note;
  /// The option's default where it is not the parameter's (a live window vs. a record's).
  std::string option_default_note;
  bool required = false;
  SettingRange range;                ///< kNumber, kInteger
  std::vector<std::string> choices;  ///< kChoice
  std::string help;                  ///< one line, present tense
  std::string group;                 ///< the section it is listed under

  /// Modifiers for the declaration lists: `number_setting(...).noted("input_period")`.
  SettingDeclaration& noted(std::string note) { default_note = std::move(note); return *this; }
  SettingDeclaration& option_noted(std::string note) { option_default_note = std::move(note); return *this; }
  SettingDeclaration& made_required() { required = true; return *this; }
  SettingDeclaration& aliased(std::vector<std::string> names) { core_aliases = std::move(names); return *this; }
  SettingDeclaration& in(std::string unit_name) { unit = std::move(unit_name); return *this; }

  /// "0.0002", "true", "robust", "\"\"", or the note.
  std::string default_text() const;
  /// The option's default as --help and docs/programs.md show it.
  std::string option_default_text() const;
  /// "" when `value` fits the declaration, else the problem in words ("must be > 0 s, not -1").
  std::string problem(const SettingValue& value) const;
  /// A value from text (a command-line argument). Throws std::invalid_argument with the problem.
  SettingValue parse(const std::string& text) const;
};

/// A value as text for messages and documents: numbers as %g, flags true/false.
std::string setting_value_text(const SettingValue& value);

/// Factories for the declaration lists (pipeline/setting_declarations.hpp and the instruments').
SettingDeclaration number_setting(std::string key, std::string parameter, std::string option, std::string unit,
                                  double default_value, SettingRange range, std::string help);
SettingDeclaration integer_setting(std::string key, std::string parameter, std::string option, std::string unit,
                                   long long default_value, SettingRange range, std::string help);
SettingDeclaration flag_setting(std::string key, std::string parameter, std::string option, bool default_value,
                                std::string help);
SettingDeclaration choice_setting(std::string key, std::string parameter, std::string option,
                                  std::vector<std::string> choices, std::string default_value, std::string help);
SettingDeclaration text_setting(SettingKind kind, std::string key, std::string parameter, std::string option,
                                std::string default_value, std::string help);

/// The declarations of one front end, in the order the documents list them.
using SettingDeclarations = std::vector<SettingDeclaration>;

/// The declaration of `key` (or of a core alias of it), or nullptr.
const SettingDeclaration* find_setting(const SettingDeclarations& declarations, const std::string& key);
/// The declaration whose parameter is `parameter`, or nullptr.
const SettingDeclaration* find_parameter(const SettingDeclarations& declarations, const std::string& parameter);

/// A group's declarations: sets `group` on each (for the lists' readability).
SettingDeclarations setting_group(const std::string& group, SettingDeclarations declarations);
/// The lists one after the other.
SettingDeclarations joined_settings(const std::vector<SettingDeclarations>& lists);

}  // namespace magnetometer_insitu_calibration
