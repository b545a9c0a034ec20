// The one error type user-facing code throws: a single line naming the file and the field.
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

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

// For an unknown key or name: " (did you mean 'x'?)" with the candidate closest to `name` by
// edit distance, or "" when none is close enough to be a likely typo. Every parser that rejects
// an unknown key, model, loss, probe, parameter or light type appends this to its message, so a
// misspelling is answered with the valid spelling (docs/inputs.md).
std::string DidYouMean(std::string_view name, const std::vector<std::string>& candidates);

// The candidate behind DidYouMean ("" when none is close): the smallest optimal-string-alignment
// distance (Levenshtein 1966 plus Damerau 1964's adjacent transpositions, each costing 1), at
// most max(2, |name| / 3), ties to the earlier candidate; failing that, a candidate whose first
// |name| characters are within one edit of `name` (4 characters or more: a shortened name).
std::string ClosestName(std::string_view name, const std::vector<std::string>& candidates);

}  // namespace shadefit
