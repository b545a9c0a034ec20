#include "box_coordinates.h"

#include <algorithm>
#include <cmath>

namespace shadefit::fit::internal {

std::vector<double> BoxOfInternal(const Parametrization& param, const std::vector<double>& u) {
  std::vector<double> y(u.size());
  for (int i = 0; i < param.size(); ++i) {
    const EntryMap& e = param.entry(i);
    y[i] = e.lower + 0.5 * (e.upper - e.lower) * (std::sin(u[i]) + 1.0);
    y[i] = std::clamp(y[i], e.lower, e.upper);
    if (e.LmLinearOfLog()) y[i] = std::exp(y[i]);
  }
  return y;
}

std::vector<double> InternalOfBox(const Parametrization& param, const std::vector<double>& y) {
  std::vector<double> u(y.size());
  for (int i = 0; i < param.size(); ++i) {
    const EntryMap& e = param.entry(i);
    const double box = e.LmLinearOfLog() ? std::log(y[i]) : y[i];
    u[i] = Parametrization::FromBox(e, box);
  }
  return u;
}

double FractionDerivative(const Parametrization& param, int i, double u) {
  const EntryMap& e = param.entry(i);
  if (e.fixed) return 0.0;
  const double dy = 0.5 * (e.upper - e.lower);
  if (!e.LmLinearOfLog()) return dy;
  const double y = std::clamp(e.lower + 0.5 * (e.upper - e.lower) * (std::sin(u) + 1.0),
                              e.lower, e.upper);
  return std::exp(y) * dy;  // The LM works on p = exp(y) here.
}

double BoxDerivative(const Parametrization& param, int i, double u) {
  return FractionDerivative(param, i, u) * std::cos(u);
}

}  // namespace shadefit::fit::internal
