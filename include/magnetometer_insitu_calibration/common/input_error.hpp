// The one exception type for bad input: it always names where the problem is.
#pragma once

#include <map>
#include <stdexcept>
#include <string>

namespace magnetometer_insitu_calibration {

/// Bad input data or settings. what() reads "<where>: <problem>", where <where> is
/// "file:line", "file", "--option" or "parameter ~name".
class InputError : public std::runtime_error {
 public:
  InputError(const std::string& where, const std::string& problem)
      : std::runtime_error(where + ": " + problem), where_(where), problem_(problem) {}
  InputError(const std::string& file, std::size_t line, const std::string& problem)
      : InputError(file + ":" + std::to_string(line), problem) {}
  const std::string& where() const { return where_; }
  const std::string& problem() const { return problem_; }

 private:
  std::string where_;
  std::string problem_;
};

/// `error` named by names[where] when its where() is a key of `names` (a settings field, under
/// the option or parameter a user gave for it), else unchanged.
inline InputError renamed(const InputError& error, const std::map<std::string, std::string>& names) {
  const auto it = names.find(error.where());
  return it == names.end() ? error : InputError(it->second, error.problem());
}

}  // namespace magnetometer_insitu_calibration
