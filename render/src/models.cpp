#include "shadefit/render/models.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "shadefit/base/error.h"

namespace shadefit {
namespace {

std::vector<ModelInfo> BuildModels() {
  std::vector<ModelInfo> models;
  for (int i = 0; i < kModelCount; ++i) {
    const auto id = static_cast<ModelId>(i);
    VisitModel(id, [&](auto tag) {
      using M = typename decltype(tag)::template Of<double, double>;
      models.push_back({id, M::Name(), M::Description(), M::Table(), ModelGlslFile(id)});
    });
  }
  return models;
}

}  // namespace

int ModelInfo::ParamCount() const {
  int n = 0;
  for (const auto& p : params) n += p.size;
  return n;
}

int ModelInfo::Offset(const std::string& name) const {
  int offset = 0;
  for (const auto& p : params) {
    if (p.name == name) return offset;
    offset += p.size;
  }
  return -1;
}

const ParamSpec* ModelInfo::Find(const std::string& name) const {
  for (const auto& p : params) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

const ParamSpec& ModelInfo::SpecOfEntry(int i) const {
  for (const auto& p : params) {
    if (i < p.size) return p;
    i -= p.size;
  }
  throw Error("", "parameter", fmt::format("index {} out of range for model {}", i, name));
}

std::string ModelInfo::EntryName(int i) const {
  for (const auto& p : params) {
    if (i < p.size) return p.size == 1 ? p.name : p.name + "." + "rgb"[i];
    i -= p.size;
  }
  return "?";
}

const std::vector<ModelInfo>& AllModels() {
  static const std::vector<ModelInfo> models = BuildModels();
  return models;
}

const ModelInfo& FindModel(const std::string& name) {
  std::string known;
  std::vector<std::string> names;
  for (const auto& m : AllModels()) {
    if (m.name == name) return m;
    known += (known.empty() ? "" : ", ") + m.name;
    names.push_back(m.name);
  }
  throw Error(
      "", "model",
      fmt::format("unknown model '{}'{} (known: {})", name, DidYouMean(name, names), known));
}

const ModelInfo& GetModel(ModelId id) {
  for (const auto& m : AllModels()) {
    if (m.id == id) return m;
  }
  throw Error("", "model", "internal: model id not registered");
}

std::vector<double> DefaultParams(const ModelInfo& model) {
  std::vector<double> values;
  for (const auto& p : model.params) values.insert(values.end(), p.size, p.default_value);
  // Sensible colour defaults differ per row only through default_value; nothing else to do.
  return values;
}

void SetParam(const ModelInfo& model, const std::string& name, const std::vector<double>& values,
              const std::string& context, std::vector<double>* params) {
  const ParamSpec* spec = model.Find(name);
  if (!spec) {
    std::string known;
    std::vector<std::string> names;
    for (const auto& p : model.params) {
      known += (known.empty() ? "" : ", ") + p.name;
      names.push_back(p.name);
    }
    throw Error(context, name,
                fmt::format("unknown parameter for model {}{} (known: {})", model.name,
                            DidYouMean(name, names), known));
  }
  if (values.size() != 1 && static_cast<int>(values.size()) != spec->size) {
    throw Error(context, name,
                fmt::format("expected {} value(s), got {}", spec->size, values.size()));
  }
  const int offset = model.Offset(name);
  for (int c = 0; c < spec->size; ++c) {
    const double v = values.size() == 1 ? values[0] : values[c];
    if (!std::isfinite(v) || v < spec->min || v > spec->max) {
      throw Error(context, name, fmt::format("value {} outside [{}, {}]", v, spec->min, spec->max));
    }
    (*params)[offset + c] = v;
  }
}

void SetParamFromString(const ModelInfo& model, const std::string& assignment,
                        const std::string& context, std::vector<double>* params) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw Error(context, assignment, "expected name=value or name=v1,v2,v3");
  }
  const std::string name = assignment.substr(0, eq);
  std::vector<double> values;
  std::stringstream ss(assignment.substr(eq + 1));
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      std::size_t used = 0;
      values.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw Error(context, name, fmt::format("'{}' is not a number", item));
    }
  }
  if (values.empty()) throw Error(context, name, "no value given");
  SetParam(model, name, values, context, params);
}

FixedValue ParseFixedValue(const ModelInfo& model, const std::string& assignment,
                           const std::string& context) {
  std::vector<double> params = DefaultParams(model);
  SetParamFromString(model, assignment, context, &params);
  const std::string name = assignment.substr(0, assignment.find('='));
  FixedValue f;
  f.param = model.Find(name);
  const auto first = params.begin() + model.Offset(name);
  f.values.assign(first, first + f.param->size);
  f.given = assignment;
  return f;
}

std::vector<FixedValue> ParseFixedValues(const ModelInfo& model,
                                         const std::vector<std::string>& assignments,
                                         const std::string& context) {
  std::vector<FixedValue> out;
  for (const std::string& a : assignments) out.push_back(ParseFixedValue(model, a, context));
  return out;
}

std::vector<std::string> FixedTexts(const std::vector<FixedValue>& fixed) {
  std::vector<std::string> out;
  for (const FixedValue& f : fixed) out.push_back(f.given);
  return out;
}

double SpecularLobeAlpha(ModelId id, const double* p) {
  return VisitModel(id, [&](auto tag) {
    using M = typename decltype(tag)::template Of<double, double>;
    return M::LobeAlpha(M::Load(p));
  });
}

const ParamSpec* ModelInfo::WidthParam() const {
  for (const auto& p : params) {
    if (p.roles & kWidthParam) return &p;
  }
  return nullptr;
}

std::vector<double> SpecularOnlyParams(const ModelInfo& model) {
  std::vector<double> values = DefaultParams(model);
  int offset = 0;
  for (const auto& p : model.params) {
    double v = values[offset];
    if (p.roles & kDiffuseParam) v = 0.0;
    if (p.roles & kSpecularParam) v = 1.0;
    v = std::clamp(v, p.min, p.max);
    for (int c = 0; c < p.size; ++c) values[offset + c] = v;
    offset += p.size;
  }
  return values;
}

double SetWidthForAlpha(const ModelInfo& model, double alpha, std::vector<double>* params) {
  const ParamSpec* width = model.WidthParam();
  if (!width || width->size != 1) {
    throw Error("", "model", fmt::format("model {} has no lobe width parameter", model.name));
  }
  const int at = model.Offset(width->name);
  // Bisection in the row's fitting space (log for log rows); LobeAlpha rises with roughness and
  // falls with an exponent, so the bracket's orientation comes from its two ends.
  auto to_value = [&](double u) { return width->log_scale ? std::exp(u) : u; };
  double lo = width->log_scale ? std::log(width->min) : width->min;
  double hi = width->log_scale ? std::log(width->max) : width->max;
  auto alpha_at = [&](double u) {
    (*params)[at] = to_value(u);
    return SpecularLobeAlpha(model.id, params->data());
  };
  const bool rising = alpha_at(hi) > alpha_at(lo);
  for (int i = 0; i < 200 && hi - lo > 1e-15 * std::max(1.0, std::abs(hi)); ++i) {
    const double mid = 0.5 * (lo + hi);
    ((alpha_at(mid) < alpha) == rising ? lo : hi) = mid;
  }
  (*params)[at] = to_value(0.5 * (lo + hi));
  return (*params)[at];
}

}  // namespace shadefit
