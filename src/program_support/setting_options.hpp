// Command-line options from the declared settings (common/setting_bindings.hpp): one option per
// bound setting with an `option`, its help, unit and default from the declaration; a flag gets
// its negation (--trend, --no-trend); two settings that share an option take LOW:HIGH (--band).
// Values are checked against their declaration once, after parsing, and errors name the option.
#pragma once

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/setting_bindings.hpp"

#include <CLI/CLI.hpp>

#include <deque>
#include <stdexcept>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// The help line of a declared option: "help (unit)" and, for a flag, whether it is on.
inline std::string option_help(const SettingDeclaration& d) {
  std::string text = d.help;
  if (!d.unit.empty() && d.unit != "-") text += " (" + d.unit + ")";
  if (d.kind == SettingKind::kFlag) {
    text += setting_value_text(d.default_value) == "true" ? "; on by default" : "; off by default";
    if (!d.option_default_note.empty()) text += " (" + d.option_default_note + ")";
  }
  return text;
}

/// The value's name in --help: NUMBER, INT, or the choices.
inline std::string option_type_name(const SettingDeclaration& d) {
  switch (d.kind) {
    case SettingKind::kNumber: return "NUMBER";
    case SettingKind::kInteger: return "INT";
    case SettingKind::kPath: return "FILE";
    case SettingKind::kChoice: {
      std::string names;
      for (const std::string& c : d.choices) names += (names.empty() ? "" : "|") + c;
      return names;
    }
    default: return "TEXT";
  }
}

template <class Root>
class SettingOptions {
 public:
  /// Adds the options of every binding in `bindings` with an option to `app`.
  SettingOptions(CLI::App& app, const SettingBindings<Root>& bindings) {
    for (const SettingBinding<Root>* bound : bindings.in_declared_order()) {
      const SettingBinding<Root>& b = *bound;
      if (b.declared.option.empty()) continue;
      Entry* partner = find_option(b.declared.option);
      if (partner != nullptr) {  // a LOW:HIGH pair: the option reads both
        partner->second = &b;
        partner->option->description(partner->first->declared.help + "; " + b.declared.help + " (" +
                                     b.declared.unit + ")");
        partner->option->default_str(partner->first->declared.option_default_text() + ":" +
                                     b.declared.option_default_text());
        partner->option->type_name("LOW:HIGH");
        continue;
      }
      Entry& e = entries_.emplace_back();
      e.first = &b;
      const SettingDeclaration& d = b.declared;
      if (d.kind == SettingKind::kFlag) {
        const std::string name = d.option + ",!--no-" + d.option.substr(2);
        e.option = app.add_flag(name, e.flag, option_help(d));
      } else {
        e.option = app.add_option(d.option, e.text, option_help(d))
                       ->default_str(d.option_default_text())
                       ->type_name(option_type_name(d));
      }
      if (!d.group.empty()) e.option->group(d.group);
    }
  }

  /// Whether the user gave the option of `key`.
  bool given(const std::string& key) const {
    for (const Entry& e : entries_)
      if (e.first->declared.key == key || (e.second != nullptr && e.second->declared.key == key))
        return e.option->count() > 0;
    return false;
  }

  /// Every given option: parsed, checked against its declaration and set in `root`.
  /// Throws InputError naming the option.
  void apply(Root& root) const {
    for (const Entry& e : entries_) {
      if (e.option->count() == 0) continue;
      const SettingDeclaration& d = e.first->declared;
      if (d.kind == SettingKind::kFlag) {
        set(*e.first, root, SettingValue(e.flag));
      } else if (e.second == nullptr) {
        set(*e.first, root, parsed(d, e.text));
      } else {
        const auto colon = e.text.find(':');
        if (colon == std::string::npos) {
          throw InputError(d.option, "expected LOW:HIGH in " + d.unit + ", e.g. " +
                                         e.option->get_default_str() + ", got '" + e.text + "'");
        }
        set(*e.first, root, parsed(d, e.text.substr(0, colon)));
        set(*e.second, root, parsed(e.second->declared, e.text.substr(colon + 1)));
      }
    }
  }

  /// A core check's error (where = a settings key) named by the option that sets it.
  InputError named_by_option(const InputError& error) const {
    for (const Entry& e : entries_) {
      for (const SettingBinding<Root>* b : {e.first, e.second}) {
        if (b == nullptr) continue;
        const SettingDeclaration& d = b->declared;
        bool match = d.key == error.where();
        for (const std::string& alias : d.core_aliases) match = match || alias == error.where();
        if (match) return InputError(d.option, error.problem());
      }
    }
    return error;
  }

 private:
  struct Entry {
    const SettingBinding<Root>* first = nullptr;
    const SettingBinding<Root>* second = nullptr;  ///< the HIGH of a LOW:HIGH option
    CLI::Option* option = nullptr;
    std::string text;
    bool flag = false;
  };

  Entry* find_option(const std::string& option) {
    for (Entry& e : entries_)
      if (e.first->declared.option == option) return &e;
    return nullptr;
  }

  static SettingValue parsed(const SettingDeclaration& d, const std::string& text) {
    try {
      return d.parse(text);
    } catch (const std::invalid_argument& e) {
      throw InputError(d.option, e.what());
    }
  }

  static void set(const SettingBinding<Root>& b, Root& root, const SettingValue& value) {
    const std::string problem = b.declared.problem(value);
    if (!problem.empty()) throw InputError(b.declared.option, problem);
    try {
      b.set(root, value);
    } catch (const InputError& e) {
      throw InputError(b.declared.option, e.problem());
    }
  }

  std::deque<Entry> entries_;  // stable addresses: CLI11 writes into text and flag
};

}  // namespace magnetometer_insitu_calibration
