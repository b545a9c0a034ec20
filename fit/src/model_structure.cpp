#include "model_structure.h"

#include <ceres/jet.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <utility>

namespace shadefit::fit::internal {
namespace {

// Fixed pseudo-random numbers for the structure checks below (splitmix64, Steele, Lea and Flood
// 2014): the same configurations on every platform and run.
class StructureRng {
 public:
  explicit StructureRng(std::uint64_t seed) : state_(seed) {}
  double Uniform() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return static_cast<double>((z ^ (z >> 31)) >> 11) * 0x1.0p-53;
  }
  // A direction above the surface z = 0, at least ~11 degrees above the horizon.
  Vec3d Hemisphere() {
    const double z = 0.2 + 0.8 * Uniform(), phi = 2 * kPi * Uniform();
    const double r = std::sqrt(1 - z * z);
    return Vec3d{r * std::cos(phi), r * std::sin(phi), z};
  }

 private:
  std::uint64_t state_;
};

// Entry i of a model at a generic point inside its table (log rows within 1e-2..1e2), as a
// per-entry Jet seeded in slot i: the structure checks below read which slots each output has.
template <typename Jet>
void GenericEntries(const std::vector<ParamSpec>& table, StructureRng& rng, Jet* p) {
  int i = 0;
  for (const ParamSpec& row : table) {
    for (int c = 0; c < row.size; ++c, ++i) {
      const double lo = row.log_scale ? std::log(std::max(row.min, 1e-2)) : row.min;
      const double hi = row.log_scale ? std::log(std::min(row.max, 1e2)) : row.max;
      const double t = lo + (0.1 + 0.8 * rng.Uniform()) * (hi - lo);
      p[i] = Jet(row.log_scale ? std::exp(t) : t, i);
    }
  }
}

// fn(Tag{}), computed on the first call for that model and kept (a function-local static per
// Tag and fn: thread-safe). A fit pays for its own model's structure checks only: computed for
// every model at the first call, they took about 1 ms of a one-start ggx fit's 8 ms solve.
template <typename Tag, typename Fn>
const auto& OncePerModel(const Fn& fn) {
  static const auto value = fn(Tag{});
  return value;
}

// The rows each output of model M reads: over kProbeConfigurations generic configurations
// (random geometry above the surface, parameters inside their boxes), which entries have a
// non-zero derivative in each channel of the Diffuse and Fresnel terms and of the ambient
// reflectance, and in the Lobe, from the full per-entry Jet. Coupling that vanished at all of
// them is not credible.
constexpr int kProbeConfigurations = 24;

struct JetDependence {
  std::vector<ParamSpec> table;
  std::vector<int> row_of, channel_of;  // Per entry: its row, its channel (-1: a scalar row).
  // [term][channel][entry]: Diffuse, Fresnel, Lobe (channel 0 only), Ambient.
  std::array<std::array<std::vector<bool>, 3>, 4> reads;
};

template <typename Tag>
JetDependence JetDependenceOf() {
  constexpr int P = Tag::template Of<double, double>::kParamCount;
  using Jet = ceres::Jet<double, P>;
  using M = typename Tag::template Of<Jet, double>;
  JetDependence out;
  out.table = M::Table();
  for (int r = 0; r < static_cast<int>(out.table.size()); ++r) {
    for (int c = 0; c < out.table[r].size; ++c) {
      out.row_of.push_back(r);
      out.channel_of.push_back(out.table[r].size == 3 ? c : -1);
    }
  }
  for (auto& term : out.reads) {
    for (auto& channel : term) channel.assign(P, false);
  }
  StructureRng rng(0x9e3779b97f4a7c15ull);
  for (int trial = 0; trial < kProbeConfigurations; ++trial) {
    Jet p[P];
    GenericEntries(out.table, rng, p);
    const ShadingDots<double> d =
        ComputeShadingDots(Vec3d{0, 0, 1}, rng.Hemisphere(), rng.Hemisphere());
    const typename M::Params q = M::Load(p);
    const Rgb<Jet> diffuse = M::Diffuse(q, d), fresnel = M::Fresnel(q, d), ambient = M::Ambient(q);
    const Jet lobe = M::Lobe(q, d);
    for (int e = 0; e < P; ++e) {
      for (int c = 0; c < 3; ++c) {
        if (diffuse[c].v[e] != 0.0) out.reads[0][c][e] = true;
        if (fresnel[c].v[e] != 0.0) out.reads[1][c][e] = true;
        if (ambient[c].v[e] != 0.0) out.reads[3][c][e] = true;
      }
      if (lobe.v[e] != 0.0) out.reads[2][0][e] = true;
    }
  }
  return out;
}

// Whether each output channel of model M depends on channel c of its colour rows only (kd.r
// on red alone, ...), as for every model whose colours are not mixed (every shipped model; a
// luminance tint, Burley 2012's specular or sheen tint, would mix them, and such a model gets
// the per-entry Jet). Then one Jet slot per row carries the derivatives of all three
// channels, a slot's value in output c being the derivative with respect to the row's channel
// c: a Jet of rows + 1 slots instead of entries + 1 (ggx: 4 instead of 8). The radiance's
// channel c is Diffuse_c n.l + Fresnel_c Lobe (+ Ambient_c), so it reads what those read.
template <typename Tag>
bool ChannelSeparableImpl() {
  const JetDependence dep = JetDependenceOf<Tag>();
  for (int c = 0; c < 3; ++c) {
    for (int e = 0; e < static_cast<int>(dep.channel_of.size()); ++e) {
      if (dep.channel_of[e] < 0 || dep.channel_of[e] == c) continue;
      for (int term : {0, 1, 3}) {
        if (dep.reads[term][c][e]) return false;
      }
      // The lobe is one scalar for all three channels.
      if (dep.reads[2][0][e]) return false;
    }
  }
  return true;
}

// TermRows (above): per term, the rows with a non-zero derivative in any channel.
template <typename Tag>
TermRows TermRowsImpl() {
  const JetDependence dep = JetDependenceOf<Tag>();
  TermRows out;
  out.single = true;
  int* slot[3] = {&out.diffuse, &out.fresnel, &out.lobe};
  for (int t = 0; t < 3; ++t) {
    std::vector<bool> rows(dep.table.size(), false);
    for (int c = 0; c < 3; ++c) {
      for (int e = 0; e < static_cast<int>(dep.row_of.size()); ++e) {
        if (dep.reads[t][c][e]) rows[dep.row_of[e]] = true;
      }
    }
    for (int r = 0; r < static_cast<int>(rows.size()); ++r) {
      if (!rows[r]) continue;
      if (*slot[t] >= 0) out.single = false;
      *slot[t] = r;
    }
  }
  return out;
}

// The range the affinity probes below draw a row's values from (its middle 40%, steps of a
// quarter): the table's box, cut to 100 wide, and to 10 for log rows. A lobe exponent of 30-70
// left Lafortune's lobe (C_xy, C_z in [-1, 1], raised to n) at 1e-35 of the diffuse term, so
// every difference in C vanished "to rounding" and C_z was taken for a linear entry, which
// variable projection then solved as one (a lafortune fit stopped at its start, cost 1e9 times
// Ceres').
std::pair<double, double> ProbeRange(const ParamSpec& row) {
  return {row.min, std::min(row.max, row.min + (row.log_scale ? 10.0 : 100.0))};
}

// Which entries the model's radiance is affine in, jointly (variable projection, below): the
// second difference along each entry and the mixed difference of each pair vanish at 24
// generic configurations (as JetDependenceOf's), to rounding. Greedy in table order, so of
// a bilinear pair (ggx-metallic's base_color and metallic) the first row is kept.
template <typename Tag>
std::vector<bool> LinearEntriesImpl() {
  using M = typename Tag::template Of<double, double>;
  constexpr int P = M::kParamCount;
  const std::vector<ParamSpec> table = M::Table();
  std::vector<const ParamSpec*> spec_of;
  for (const ParamSpec& row : table) {
    for (int c = 0; c < row.size; ++c) spec_of.push_back(&row);
  }
  StructureRng rng(0x2545f4914f6cdd1dull);
  struct Config {
    ShadingDots<double> d;
    double p[P];
    double step[P];
  };
  std::vector<Config> configs(kProbeConfigurations);
  for (Config& cfg : configs) {
    for (int i = 0; i < P; ++i) {
      const ParamSpec& row = *spec_of[i];
      const auto [lo, hi] = ProbeRange(row);
      cfg.p[i] = lo + (0.3 + 0.4 * rng.Uniform()) * (hi - lo);
      cfg.step[i] = 0.25 * (hi - lo);
    }
    cfg.d = ComputeShadingDots(Vec3d{0, 0, 1}, rng.Hemisphere(), rng.Hemisphere());
  }
  // Radiance of the three terms (ambient light 1) at p with entries i, j moved by a, b steps.
  auto radiance = [](const Config& cfg, int i, double a, int j, double b, double* out) {
    double p[P];
    std::copy(cfg.p, cfg.p + P, p);
    if (i >= 0) p[i] += a * cfg.step[i];
    if (j >= 0) p[j] += b * cfg.step[j];
    const typename M::Params q = M::Load(p);
    const Rgb<double> r = Reflected<M, double>(q, cfg.d) + M::Ambient(q);
    for (int c = 0; c < 3; ++c) out[c] = r[c];
  };
  // Whether sum_k w_k R(p + a_k e_i + b_k e_j) vanishes to rounding at every configuration.
  auto vanishes = [&](int i, int j, const double (&terms)[4][3]) {
    for (const Config& cfg : configs) {
      double sum[3] = {0, 0, 0}, size[3] = {0, 0, 0};
      for (const auto& t : terms) {
        if (t[0] == 0) continue;
        double r[3];
        radiance(cfg, i, t[1], j, t[2], r);
        for (int c = 0; c < 3; ++c) {
          sum[c] += t[0] * r[c];
          size[c] += std::abs(t[0] * r[c]);
        }
      }
      for (int c = 0; c < 3; ++c) {
        if (!std::isfinite(sum[c]) || std::abs(sum[c]) > 1e-10 * size[c] + 1e-300) return false;
      }
    }
    return true;
  };
  std::vector<bool> linear(P, false);
  for (int i = 0; i < P; ++i) {
    if (!vanishes(i, -1, {{1, 1, 0}, {-2, 0, 0}, {1, -1, 0}, {0, 0, 0}})) continue;
    bool joint = true;
    for (int j = 0; j < i && joint; ++j) {
      if (linear[j]) joint = vanishes(i, j, {{1, 1, 1}, {-1, 1, 0}, {-1, 0, 1}, {1, 0, 0}});
    }
    linear[i] = joint;
  }
  return linear;
}

// Whether the radiance is linear, not only affine, in its linear entries jointly: zero when they
// are all zero, at kProbeConfigurations generic configurations (ambient light 1), to rounding.
// Then exposure * radiance(x) = radiance(exposure * x) for those entries x: a free exposure and
// they share one scale exactly (exposure_pin.h).
template <typename Tag>
bool HomogeneousImpl() {
  using M = typename Tag::template Of<double, double>;
  constexpr int P = M::kParamCount;
  const std::vector<ParamSpec> table = M::Table();
  const std::vector<bool> linear = LinearEntriesImpl<Tag>();
  if (std::find(linear.begin(), linear.end(), true) == linear.end()) return false;
  StructureRng rng(0x9fb21c651e98df25ull);
  for (int k = 0; k < kProbeConfigurations; ++k) {
    double p[P];
    int i = 0;
    for (const ParamSpec& row : table) {
      const auto [lo, hi] = ProbeRange(row);
      for (int c = 0; c < row.size; ++c, ++i) p[i] = lo + (0.3 + 0.4 * rng.Uniform()) * (hi - lo);
    }
    const ShadingDots<double> d =
        ComputeShadingDots(Vec3d{0, 0, 1}, rng.Hemisphere(), rng.Hemisphere());
    const Rgb<double> full = Reflected<M, double>(M::Load(p), d) + M::Ambient(M::Load(p));
    for (int j = 0; j < P; ++j) {
      if (linear[j]) p[j] = 0;
    }
    const Rgb<double> zero = Reflected<M, double>(M::Load(p), d) + M::Ambient(M::Load(p));
    for (int c = 0; c < 3; ++c) {
      if (!(std::abs(zero[c]) <= 1e-12 * std::abs(full[c]) + 1e-300)) return false;
    }
  }
  return true;
}

// AmbientOnlyEntries (model_structure.h): read by the ambient term and by no other.
template <typename Tag>
std::vector<bool> AmbientOnlyImpl() {
  const JetDependence dep = JetDependenceOf<Tag>();
  std::vector<bool> out(dep.row_of.size(), false);
  for (int e = 0; e < static_cast<int>(out.size()); ++e) {
    bool ambient = false, other = dep.reads[2][0][e];
    for (int c = 0; c < 3; ++c) {
      ambient = ambient || dep.reads[3][c][e];
      other = other || dep.reads[0][c][e] || dep.reads[1][c][e];
    }
    out[e] = ambient && !other;
  }
  return out;
}

}  // namespace

std::vector<bool> AmbientOnlyEntries(ModelId model) {
  return VisitModel(model, [](auto tag) -> std::vector<bool> {
    return OncePerModel<decltype(tag)>([](auto t) { return AmbientOnlyImpl<decltype(t)>(); });
  });
}

bool HomogeneousInLinearEntries(ModelId model) {
  return VisitModel(model, [](auto tag) -> bool {
    return OncePerModel<decltype(tag)>([](auto t) { return HomogeneousImpl<decltype(t)>(); });
  });
}

bool ChannelSeparable(ModelId model) {
  return VisitModel(model, [](auto tag) -> bool {
    return OncePerModel<decltype(tag)>([](auto t) { return ChannelSeparableImpl<decltype(t)>(); });
  });
}

const TermRows& RowsOfTerms(ModelId model) {
  return VisitModel(model, [](auto tag) -> const TermRows& {
    return OncePerModel<decltype(tag)>([](auto t) { return TermRowsImpl<decltype(t)>(); });
  });
}

std::vector<bool> LinearEntries(ModelId model) {
  return VisitModel(model, [](auto tag) -> std::vector<bool> {
    return OncePerModel<decltype(tag)>([](auto t) { return LinearEntriesImpl<decltype(t)>(); });
  });
}

}  // namespace shadefit::fit::internal
