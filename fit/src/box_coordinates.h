// The bounded LM's coordinates of a parametrisation's entries (internal to fit/): y = log p for
// the entries EntryMap::lm_log marks, else p itself, in its box [lower, upper] (or [exp(lower),
// exp(upper)] for the sine path's log entries: EntryMap::LmLinearOfLog); and the maps between
// them and the sine transform's internal u (residuals.h), which the multi-start and the
// uncertainty use to move between the two solvers.
#pragma once

#include <vector>

#include "shadefit/fit/residuals.h"

namespace shadefit::fit::internal {

// Box of entry i in the bounded LM's coordinates.
inline void BoxOf(const Parametrization& param, int i, double* lo, double* hi) {
  const EntryMap& e = param.entry(i);
  const bool linear_of_log = e.LmLinearOfLog();
  *lo = linear_of_log ? std::exp(e.lower) : e.lower;
  *hi = linear_of_log ? std::exp(e.upper) : e.upper;
}

// Natural parameters of box coordinates y (fixed entries: their value).
template <typename T>
void NaturalOfBox(const Parametrization& param, const T* y, T* p) {
  using std::exp;
  for (int i = 0; i < param.size(); ++i) {
    const EntryMap& e = param.entry(i);
    if (e.fixed) {
      p[i] = T(e.fixed_value);
    } else {
      p[i] = e.lm_log ? exp(y[i]) : y[i];
    }
  }
}

// Box coordinates y of internal u (fixed entries: their u, unused) and back.
std::vector<double> BoxOfInternal(const Parametrization& param, const std::vector<double>& u);
std::vector<double> InternalOfBox(const Parametrization& param, const std::vector<double>& y);

// d y_i / d u_i of entry i at internal u (0 for fixed entries): the chain factor from the
// bounded LM's coordinates to the sine transform's.
double BoxDerivative(const Parametrization& param, int i, double u);
// d y_i / d s_i, s = sin u the fraction of the box: finite on the bounds too.
double FractionDerivative(const Parametrization& param, int i, double u);

}  // namespace shadefit::fit::internal
