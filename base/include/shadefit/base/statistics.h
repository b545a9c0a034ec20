// Order statistics: the one percentile rule of every stage (issue 35).
//
// Percentile(values, q) is the value of 0-based rank floor(q n) among the n values once sorted
// (clamped to n - 1): an element of the data, never an interpolation between two, found in
// O(n) by std::nth_element. For q = 1/2 it is the upper median (index n / 2), for q = 0.9 the
// element n * 9 / 10 of the sorted values. It is the rule a threshold wants (a preview's p99, the
// bright pixels above p90, an import's p99.5 white), and the one the code used in seven of its
// nine places; the other two (a floor(q (n - 1)) index and a linear interpolation) now use it.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

namespace shadefit {

// The index Percentile reads: floor(q n) clamped to [0, n - 1], q in [0, 1]. The 1e-6 absorbs
// the rounding of q n for the decimal fractions used (0.5, 0.9, 0.99, 0.995): q n is then either
// an integer or at least 0.001 from one, so floor sees the exact value's integer part.
inline std::size_t PercentileIndex(std::size_t n, double q) {
  if (n == 0) return 0;
  const double position = std::clamp(q, 0.0, 1.0) * static_cast<double>(n) + 1e-6;
  return std::min(n - 1, static_cast<std::size_t>(std::floor(position)));
}

// The q-th fraction's order statistic of `values` (reordered in place); NaN (or T's quiet NaN)
// for no value.
template <typename T>
T Percentile(std::vector<T>& values, double q) {
  if (values.empty()) {
    return std::numeric_limits<T>::has_quiet_NaN ? std::numeric_limits<T>::quiet_NaN() : T{};
  }
  const auto at = values.begin() + static_cast<std::ptrdiff_t>(PercentileIndex(values.size(), q));
  std::nth_element(values.begin(), at, values.end());
  return *at;
}

}  // namespace shadefit
