#include "shadefit/base/error.h"

#include <algorithm>
#include <cctype>

namespace shadefit {
namespace {

// Optimal string alignment distance, case-insensitive: insertions, deletions, substitutions and
// transpositions of two adjacent characters cost 1 each (Damerau 1964, "A technique for computer
// detection and correction of spelling errors"; Levenshtein 1966). Names here are short (keys,
// model names), so the full (|a| + 1) x (|b| + 1) table is cheap.
std::size_t EditDistance(std::string_view a, std::string_view b) {
  auto lower = [](char c) {
    return static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  };
  const std::size_t n = a.size(), m = b.size();
  std::vector<std::size_t> d((n + 1) * (m + 1));
  auto at = [&](std::size_t i, std::size_t j) -> std::size_t& { return d[i * (m + 1) + j]; };
  for (std::size_t i = 0; i <= n; ++i) at(i, 0) = i;
  for (std::size_t j = 0; j <= m; ++j) at(0, j) = j;
  for (std::size_t i = 1; i <= n; ++i) {
    for (std::size_t j = 1; j <= m; ++j) {
      const std::size_t cost = lower(a[i - 1]) == lower(b[j - 1]) ? 0 : 1;
      at(i, j) = std::min({at(i - 1, j) + 1, at(i, j - 1) + 1, at(i - 1, j - 1) + cost});
      if (i > 1 && j > 1 && lower(a[i - 1]) == lower(b[j - 2]) &&
          lower(a[i - 2]) == lower(b[j - 1])) {
        at(i, j) = std::min(at(i, j), at(i - 2, j - 2) + 1);
      }
    }
  }
  return at(n, m);
}

}  // namespace

std::string ClosestName(std::string_view name, const std::vector<std::string>& candidates) {
  // A name longer than any key we know is not a typo of one; bounding it also bounds the table.
  if (name.empty() || name.size() > 256) return "";
  const std::size_t limit = std::max<std::size_t>(2, name.size() / 3);
  std::string best;
  std::size_t best_distance = limit + 1;
  for (const std::string& c : candidates) {
    const std::size_t dist = EditDistance(name, c);
    if (dist < best_distance) {
      best_distance = dist;
      best = c;
    }
  }
  if (best.empty() && name.size() >= 4) {
    // A shortened name ("shine" for "shininess") is far in edit distance but plainly meant: it
    // is within one edit of the candidate's start.
    for (const std::string& c : candidates) {
      if (c.size() > name.size() && EditDistance(name, c.substr(0, name.size())) <= 1) return c;
    }
  }
  return best;
}

std::string DidYouMean(std::string_view name, const std::vector<std::string>& candidates) {
  const std::string best = ClosestName(name, candidates);
  return best.empty() ? "" : " (did you mean '" + best + "'?)";
}

}  // namespace shadefit
