// Declared settings bound to the fields they set in one settings struct (Root). A front end reads
// a value under the declaration's name, checks it against the declaration once and sets it
// through the binding; a core check that names a field (InputError::where = the key) is told in
// the front end's own spelling by the declaration.
#pragma once

#include "magnetometer_insitu_calibration/common/setting_declaration.hpp"

#include <cstddef>
#include <functional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace magnetometer_insitu_calibration {

template <class Root>
struct SettingBinding {
  SettingDeclaration declared;
  std::function<void(Root&, const SettingValue&)> set;  ///< the value already checked
  std::function<SettingValue(const Root&)> get;         ///< the field's value (for the defaults' check)
};

template <class Root>
class SettingBindings {
 public:
  explicit SettingBindings(const SettingDeclarations& declarations) : declarations_(&declarations) {}

  /// Binds the declared `key` to the field `field(root)` returns (double&, int&, std::size_t&,
  /// bool& or std::string&).
  template <class Field>
  SettingBindings& bind(const std::string& key, Field field) {
    using T = std::remove_reference_t<decltype(field(std::declval<Root&>()))>;
    SettingBinding<Root> b{declaration(key), {}, {}};
    b.set = [field](Root& root, const SettingValue& value) { assign(field(root), value); };
    b.get = [field](const Root& root) { return as_value(field(const_cast<Root&>(root))); };
    static_assert(std::is_arithmetic_v<T> || std::is_same_v<T, std::string>, "a number, flag or text field");
    bindings_.push_back(std::move(b));
    return *this;
  }

  /// Binds `key` to a conversion of its own (a choice that sets an enum, a figure that sets a
  /// spectrum). `get` gives the field's value as the declaration's kind.
  SettingBindings& bind_with(const std::string& key, std::function<void(Root&, const SettingValue&)> set,
                             std::function<SettingValue(const Root&)> get) {
    bindings_.push_back(SettingBinding<Root>{declaration(key), std::move(set), std::move(get)});
    return *this;
  }

  /// Every binding of `part` (settings of a member struct), reached from Root by `member`.
  template <class Part, class Member>
  SettingBindings& include(const SettingBindings<Part>& part, Member member) {
    for (const SettingBinding<Part>& b : part.bindings()) {
      auto set = b.set;
      auto get = b.get;
      bindings_.push_back(SettingBinding<Root>{
          b.declared, [set, member](Root& root, const SettingValue& v) { set(member(root), v); },
          [get, member](const Root& root) { return get(member(const_cast<Root&>(root))); }});
    }
    return *this;
  }

  const std::vector<SettingBinding<Root>>& bindings() const { return bindings_; }
  /// The bindings in the order of the declarations (the documents' order).
  std::vector<const SettingBinding<Root>*> in_declared_order() const {
    std::vector<const SettingBinding<Root>*> out;
    for (const SettingDeclaration& d : *declarations_)
      if (const SettingBinding<Root>* b = find(d.key)) out.push_back(b);
    return out;
  }
  const SettingBinding<Root>* find(const std::string& key) const {
    for (const SettingBinding<Root>& b : bindings_)
      if (b.declared.key == key) return &b;
    return nullptr;
  }

 private:
  const SettingDeclaration& declaration(const std::string& key) const {
    const SettingDeclaration* d = find_setting(*declarations_, key);
    if (d == nullptr) throw std::logic_error("setting '" + key + "' is bound but not declared");
    return *d;
  }

  template <class T>
  static void assign(T& field, const SettingValue& value) {
    if constexpr (std::is_same_v<T, bool>) {
      field = std::get<bool>(value);
    } else if constexpr (std::is_same_v<T, std::string>) {
      field = std::get<std::string>(value);
    } else if constexpr (std::is_integral_v<T>) {
      field = static_cast<T>(std::get<long long>(value));
    } else {
      field = std::holds_alternative<long long>(value) ? static_cast<T>(std::get<long long>(value))
                                                       : static_cast<T>(std::get<double>(value));
    }
  }
  template <class T>
  static SettingValue as_value(const T& field) {
    if constexpr (std::is_same_v<T, bool> || std::is_same_v<T, std::string>) {
      return SettingValue(field);
    } else if constexpr (std::is_integral_v<T>) {
      return SettingValue(static_cast<long long>(field));
    } else {
      return SettingValue(static_cast<double>(field));
    }
  }

  const SettingDeclarations* declarations_;
  std::vector<SettingBinding<Root>> bindings_;
};

}  // namespace magnetometer_insitu_calibration
