// The one error type user-facing code throws: a single line naming the file and the field.
#pragma once

#include <stdexcept>
#include <string>

namespace shadefit {

// Thrown for bad input and unusable environments. what() is a complete one-line message of the
// form "<file>: <field>: <problem>" (file or field omitted when there is none). The CLI prints it
// and exits non-zero; nothing is written.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
  Error(const std::string& file, const std::string& field, const std::string& problem)
      : std::runtime_error(Compose(file, field, problem)) {}

 private:
  static std::string Compose(const std::string& file, const std::string& field,
                             const std::string& problem) {
    std::string out = file;
    if (!field.empty()) out += (out.empty() ? "" : ": ") + field;
    out += (out.empty() ? "" : ": ") + problem;
    return out;
  }
};

}  // namespace shadefit
