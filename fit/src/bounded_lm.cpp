#include "bounded_lm.h"

#include <ceres/jet.h>
#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <memory>
#include <mutex>
#include <thread>
#include <type_traits>

namespace shadefit::fit::internal {
namespace {

// Pixels per partial sum. The sums of a pass are taken per chunk and then added in chunk order,
// so the result does not depend on how many threads ran the chunks.
constexpr int kChunkPixels = 1024;

struct Chunk {
  int span = 0, begin = 0, count = 0;
};

std::vector<Chunk> Chunks(const BoundedLmProblem& problem) {
  std::vector<Chunk> out;
  for (int s = 0; s < static_cast<int>(problem.spans.size()); ++s) {
    for (int k = 0; k < problem.spans[s].count; k += kChunkPixels) {
      out.push_back({s, k, std::min(kChunkPixels, problem.spans[s].count - k)});
    }
  }
  return out;
}

// Runs fn(chunk index) for every chunk on `threads` threads (chunk c on thread c % threads).
template <typename Fn>
void ForEachChunk(int chunks, int threads, const Fn& fn) {
  threads = std::max(1, std::min(threads, chunks));
  auto work = [&](int t) {
    for (int c = t; c < chunks; c += threads) fn(c);
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work, t);
  work(0);
  for (std::thread& th : pool) th.join();
}

// The Gram matrix of one group of a Jacobian pass's rows (a colour channel when the Jet has
// one slot per table row, else every residual): gram = sum q q^T over the rows
// q = [slot derivatives..., (w,) r], `unknown` the unknown each slot stands for. With `mixed`
// the row carries w, the derivative of the Fresnel-lobe product along both its rows
// (F_v L_v e: ShiftLinear).
struct GroupGram {
  std::vector<int> unknown;
  bool mixed = false;
  int fresnel = -1, lobe = -1;  // Slots of the Fresnel and lobe terms' rows (with `mixed`).
  Eigen::MatrixXd gram;
};

// One pass's sums: cost = 0.5 sum r^2, g = J^T r, h = J^T J (row-major, N x N), over the
// unknowns [y_0 .. y_{n-1}, e]; for a Jacobian pass, the Gram matrices they were scattered from.
struct Sums {
  double cost = 0;
  std::vector<double> g, h;
  bool finite = true;
  std::vector<GroupGram> groups;
};

// cost, g and h of `sums` from its groups' Gram matrices: each group's slot rows and columns
// added onto their unknowns (N of them), its residual entry onto the cost.
void ScatterGroups(int n_unknowns, Sums* sums) {
  const int N = n_unknowns;
  double cost = 0;
  std::vector<double> g(N, 0.0), h(N * N, 0.0);
  for (const GroupGram& group : sums->groups) {
    const int slots = static_cast<int>(group.unknown.size());
    const int r = static_cast<int>(group.gram.rows()) - 1;
    cost += group.gram(r, r);
    for (int a = 0; a < slots; ++a) {
      const int ia = group.unknown[a];
      g[ia] += group.gram(a, r);
      for (int b = a; b < slots; ++b) {
        const int ib = group.unknown[b];
        h[std::min(ia, ib) * N + std::max(ia, ib)] += group.gram(a, b);
      }
    }
  }
  for (int a = 0; a < N; ++a) {
    for (int b = 0; b < a; ++b) h[a * N + b] = h[b * N + a];
  }
  sums->cost = 0.5 * cost;
  sums->finite = std::isfinite(sums->cost);
  for (int i = 0; i < N * N; ++i) sums->finite = sums->finite && std::isfinite(h[i]);
  for (int i = 0; i < N; ++i) sums->finite = sums->finite && std::isfinite(g[i]);
  sums->g = std::move(g);
  sums->h = std::move(h);
}

// Moves a Jacobian pass at x to x + delta, delta non-zero on linear entries only (LinearEntries:
// the radiance is jointly affine in them), without a pass over the pixels; false (the pass left
// as it was) where its rows do not carry what that needs. Each row q = [J, (w,) r] becomes M q:
// - r' = r + J delta, exactly, the radiance being affine in the entries moved;
// - the derivative columns of the terms are their own rows' derivatives times the other terms'
//   values (Diffuse_v n.l e, Fresnel_v Lobe e, Fresnel Lobe_v e; one row per term: TermRows);
//   along a linear entry a term is affine, so its derivative does not change and its value
//   changes by delta times it: the lobe column gains delta_fresnel w, w = Fresnel_v Lobe_v e
//   (the mixed column), and no other column changes.
// So gram' = M gram M^T. The new cost is a difference of the old sums: where it falls below
// kShiftCancellation of the old one, too few of their digits are left, and the caller makes a
// fresh pass instead.
constexpr double kShiftCancellation = 1e-6;
bool ShiftLinear(const std::vector<double>& delta, Sums* sums) {
  if (sums->groups.empty()) return false;
  for (const GroupGram& group : sums->groups) {
    if (!group.mixed) return false;
  }
  const double before = sums->cost;
  Sums shifted = *sums;
  for (GroupGram& group : shifted.groups) {
    const int slots = static_cast<int>(group.unknown.size());
    const int columns = static_cast<int>(group.gram.rows());
    const int w = slots, r = columns - 1;
    Eigen::MatrixXd m = Eigen::MatrixXd::Identity(columns, columns);
    for (int a = 0; a < slots; ++a) m(r, a) += delta[group.unknown[a]];
    auto delta_of = [&](int slot) { return slot >= 0 ? delta[group.unknown[slot]] : 0.0; };
    // A lobe affine in its row would move the Fresnel column by delta_lobe w; no shipped model
    // has one (the lobes' rows are widths, or classic ks in log space), so it gets a fresh pass.
    if (delta_of(group.lobe) != 0.0) return false;
    if (group.lobe >= 0) m(group.lobe, w) += delta_of(group.fresnel);
    group.gram = m * group.gram * m.transpose();
  }
  ScatterGroups(static_cast<int>(sums->g.size()), &shifted);
  if (!shifted.finite || !(shifted.cost >= kShiftCancellation * before)) return false;
  *sums = std::move(shifted);
  return true;
}

// Whether the bounded LM works on log p for entry i (else on p itself, in [exp(lower),
// exp(upper)] for the parametrisation's log rows). The sine path fits every kMultiplicative row
// in log space because its linear-space steps stranded f0 at 0 (residuals.cpp); with bounds held
// by the active set a specular scale on its floor is released as soon as its gradient turns, and
// the image is linear in f0 and in the normalised ks (Schlick's F, the lobe's scale): in p the
// Gauss-Newton model of them is exact, in log p it is not, and a valley along f0 and kd was
// followed at ~1% per step (black-glossy-rim: cost 0.13 after 200 iterations in log f0). The
// widths (roughness: the peak goes as 1 / roughness^4) and the table's log rows (shininess,
// classic ks, spanning decades) stay in log space.
bool InBoxLog(const Parametrization& param, int i) {
  const EntryMap& e = param.entry(i);
  if (!e.log) return false;
  const ParamSpec& spec = param.model().SpecOfEntry(i);
  return spec.log_scale || (spec.roles & kWidthParam) != 0;
}

// Box of entry i in the bounded LM's coordinates.
void BoxOf(const Parametrization& param, int i, double* lo, double* hi) {
  const EntryMap& e = param.entry(i);
  const bool linear_of_log = e.log && !InBoxLog(param, i);
  *lo = linear_of_log ? std::exp(e.lower) : e.lower;
  *hi = linear_of_log ? std::exp(e.upper) : e.upper;
}

template <typename T>
T Compress(Loss loss, const T& x) {
  return CompressRadiance(loss, x);
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
      p[i] = InBoxLog(param, i) ? exp(y[i]) : y[i];
    }
  }
}

// One light sample of a shading point (point.lights, then point.environment, in that order)
// with l and v above the surface, reduced to the dot products the models read. Trivially
// default-constructible (no Vec3d, whose members are zeroed), so that an array of them is
// allocated without being written: the pages are first touched by the threads that fill them
// (a zeroing resize of 39k samples took 1.3 ms of a 2 ms PrepareGeometry, on one thread).
struct LitSample {
  ShadingDots<double> dots;
  double irradiance[3];
};

// The lit samples of every point of every span, computed once per solve instead of once per
// pass: [begin[k], begin[k + 1]) are point k's. Left empty (the passes then compute the dots
// of each sample as they go, as ShadePoint does) when there are more than kMaxLitSamples, as
// with an environment quadrature of hundreds of samples per pixel, where they would double
// the memory the points already hold.
struct SpanGeometry {
  std::vector<int> begin;
  std::unique_ptr<LitSample[]> samples;
};
struct Geometry {
  bool precomputed = false;
  std::vector<SpanGeometry> spans;
};
constexpr long kMaxLitSamples = 1L << 20;  // 88 MiB of LitSample.

bool SampleAboveSurface(const ShadingPoint& point, const PixelLight& light) {
  return Dot(point.n, light.l) > 0.0 && Dot(point.n, point.v) > 0.0;
}

// The lit samples of `problem`, in the order of its points and their lights: each point's count
// (two dot products per sample) and then its samples are computed per chunk on the problem's
// threads, with the offsets summed in between: the same values whatever the thread count.
Geometry PrepareGeometry(const BoundedLmProblem& problem, const std::vector<Chunk>& chunks) {
  Geometry geo;
  long total = 0;
  for (const PixelSpan& s : problem.spans) {
    for (int k = 0; k < s.count; ++k) {
      total += static_cast<long>(s.points[k].lights.size() + s.points[k].environment.size());
    }
  }
  if (total > kMaxLitSamples) return geo;
  geo.precomputed = true;
  for (const PixelSpan& s : problem.spans) geo.spans.emplace_back().begin.assign(s.count + 1, 0);
  ForEachChunk(static_cast<int>(chunks.size()), problem.threads, [&](int c) {
    const Chunk& chunk = chunks[c];
    const ShadingPoint* points = problem.spans[chunk.span].points;
    std::vector<int>& begin = geo.spans[chunk.span].begin;
    for (int k = chunk.begin; k < chunk.begin + chunk.count; ++k) {
      int lit = 0;
      for (const std::vector<PixelLight>* set : {&points[k].lights, &points[k].environment}) {
        for (const PixelLight& light : *set) lit += SampleAboveSurface(points[k], light) ? 1 : 0;
      }
      begin[k + 1] = lit;
    }
  });
  for (SpanGeometry& sg : geo.spans) {
    for (std::size_t k = 1; k < sg.begin.size(); ++k) sg.begin[k] += sg.begin[k - 1];
    sg.samples = std::make_unique_for_overwrite<LitSample[]>(static_cast<std::size_t>(sg.begin.back()));
  }
  ForEachChunk(static_cast<int>(chunks.size()), problem.threads, [&](int c) {
    const Chunk& chunk = chunks[c];
    const ShadingPoint* points = problem.spans[chunk.span].points;
    SpanGeometry& sg = geo.spans[chunk.span];
    for (int k = chunk.begin; k < chunk.begin + chunk.count; ++k) {
      const ShadingPoint& point = points[k];
      LitSample* out = sg.samples.get() + sg.begin[k];
      for (const std::vector<PixelLight>* set : {&point.lights, &point.environment}) {
        for (const PixelLight& light : *set) {
          if (!SampleAboveSurface(point, light)) continue;
          out->dots = ComputeShadingDots(point.n, light.l, point.v);
          for (int ch = 0; ch < 3; ++ch) out->irradiance[ch] = light.irradiance[ch];
          ++out;
        }
      }
    }
  });
  return geo;
}

bool SameSpans(const std::vector<PixelSpan>& a, const std::vector<PixelSpan>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].points != b[i].points || a[i].count != b[i].count) return false;
  }
  return true;
}

}  // namespace

struct GeometryCache {
  std::mutex mutex;
  std::vector<PixelSpan> spans;  // What `geometry` was computed for.
  std::shared_ptr<const Geometry> geometry;
};

std::shared_ptr<GeometryCache> NewGeometryCache() { return std::make_shared<GeometryCache>(); }

void ForgetGeometry(const BoundedLmProblem& problem) {
  if (!problem.geometry) return;
  std::lock_guard<std::mutex> lock(problem.geometry->mutex);
  problem.geometry->geometry.reset();
}

namespace {

// The problem's geometry: from its cache when that was computed for the same spans.
std::shared_ptr<const Geometry> GeometryOf(const BoundedLmProblem& problem,
                                           const std::vector<Chunk>& chunks) {
  if (!problem.geometry) {
    return std::make_shared<const Geometry>(PrepareGeometry(problem, chunks));
  }
  GeometryCache& cache = *problem.geometry;
  std::lock_guard<std::mutex> lock(cache.mutex);
  if (!cache.geometry || !SameSpans(cache.spans, problem.spans)) {
    cache.geometry = std::make_shared<const Geometry>(PrepareGeometry(problem, chunks));
    cache.spans = problem.spans;
  }
  return cache.geometry;
}

// add(dots, irradiance) for every lit sample of point k of span `span`: the precomputed ones,
// or those computed as ShadePoint does when the geometry was not precomputed.
template <typename Add>
void ForEachLitSample(const Geometry& geo, int span, const ShadingPoint& point, int k,
                      const Add& add) {
  if (geo.precomputed) {
    const SpanGeometry& sg = geo.spans[span];
    for (int i = sg.begin[k]; i < sg.begin[k + 1]; ++i) {
      const LitSample& sample = sg.samples[i];
      add(sample.dots, Vec3d{sample.irradiance[0], sample.irradiance[1], sample.irradiance[2]});
    }
    return;
  }
  for (const std::vector<PixelLight>* set : {&point.lights, &point.environment}) {
    for (const PixelLight& light : *set) {
      if (SampleAboveSurface(point, light)) {
        add(ComputeShadingDots(point.n, light.l, point.v), light.irradiance);
      }
    }
  }
}

// The model's reflected radiance per unit light, Reflect's sum (models.h) in its order:
// Diffuse n.l + Fresnel Lobe.
template <typename M, typename T>
Rgb<T> Reflected(const typename M::Params& q, const ShadingDots<double>& d) {
  return M::Diffuse(q, d) * T(d.NoL) + M::Fresnel(q, d) * M::Lobe(q, d);
}

// Radiance of point k of span `span` for the loaded parameters q of model M (T = double or a
// Jet), ambient reflectance ka: the arithmetic of ShadePoint and Reflect (models.h) in the same
// order, so that the cost is the same double the twin gives.
template <typename M, typename T>
void ShadeLoaded(const typename M::Params& q, const Rgb<T>& ka, const Geometry& geo, int span,
                 const ShadingPoint& point, int k, T* out) {
  for (int c = 0; c < 3; ++c) out[c] = ka[c] * T(point.ambient[c]);
  auto add = [&](const ShadingDots<double>& d, const Vec3d& irradiance) {
    const Rgb<T> r = Reflected<M, T>(q, d);
    out[0] += r.r * T(irradiance[0]);
    out[1] += r.g * T(irradiance[1]);
    out[2] += r.b * T(irradiance[2]);
  };
  ForEachLitSample(geo, span, point, k, add);
}

// Cost only (no derivatives): doubles through the twin.
template <typename M>
Sums CostPass(const BoundedLmProblem& problem, const Geometry& geo,
              const std::vector<Chunk>& chunks, const std::vector<double>& y, double e) {
  double p[M::kParamCount];
  NaturalOfBox(*problem.param, y.data(), p);
  const typename M::Params q = M::Load(p);
  const Rgb<double> ka = M::Ambient(q);
  const double scale = std::exp(e);
  std::vector<double> partial(chunks.size(), 0.0);
  ForEachChunk(static_cast<int>(chunks.size()), problem.threads, [&](int ci) {
    const Chunk& c = chunks[ci];
    const PixelSpan& s = problem.spans[c.span];
    double sum = 0;
    for (int k = c.begin; k < c.begin + c.count; ++k) {
      double rgb[3];
      ShadeLoaded<M>(q, ka, geo, c.span, s.points[k], k, rgb);
      for (int ch = 0; ch < 3; ++ch) {
        const double r = Compress(problem.loss, scale * rgb[ch]) - s.targets[3 * k + ch];
        sum += r * r;
      }
    }
    partial[ci] = sum;
  });
  Sums out;
  for (double v : partial) out.cost += v;
  out.cost *= 0.5;
  out.finite = std::isfinite(out.cost);
  return out;
}

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

// Whether each output channel of model M depends on channel c of its colour rows only (kd.r
// on red alone, ...), as for every model whose colours are not mixed (every shipped model; a
// luminance tint, Burley 2012's specular or sheen tint, would mix them, and such a model gets
// the per-entry Jet). Then one Jet slot per row carries the derivatives of all three
// channels, a slot's value in output c being the derivative with respect to the row's channel
// c: a Jet of rows + 1 slots instead of entries + 1 (ggx: 4 instead of 8). Decided once per
// model from the full Jet at 24 generic configurations (random geometry above the surface,
// parameters inside their boxes); coupling that vanished at all of them is not credible.
template <typename Tag>
bool ChannelSeparableImpl() {
  constexpr int P = Tag::template Of<double, double>::kParamCount;
  using Jet = ceres::Jet<double, P>;
  using M = typename Tag::template Of<Jet, double>;
  const std::vector<ParamSpec> table = M::Table();
  std::vector<int> channel;
  for (const ParamSpec& row : table) {
    for (int c = 0; c < row.size; ++c) channel.push_back(row.size == 3 ? c : -1);
  }
  StructureRng rng(0x9e3779b97f4a7c15ull);
  for (int trial = 0; trial < 24; ++trial) {
    Jet p[P];
    GenericEntries(table, rng, p);
    const Vec3d n{0, 0, 1}, l = rng.Hemisphere(), v = rng.Hemisphere();
    const ShadingDots<double> d = ComputeShadingDots(n, l, v);
    const typename M::Params q = M::Load(p);
    const Rgb<Jet> r = Reflected<M, Jet>(q, d);
    const Rgb<Jet> a = M::Ambient(q);
    for (int c = 0; c < 3; ++c) {
      for (int e = 0; e < P; ++e) {
        if (channel[e] < 0 || channel[e] == c) continue;
        if (r[c].v[e] != 0.0 || a[c].v[e] != 0.0) return false;
      }
    }
  }
  return true;
}

}  // namespace

bool ChannelSeparable(ModelId model) {
  return VisitModel(model, [](auto tag) -> bool {
    return OncePerModel<decltype(tag)>([](auto t) { return ChannelSeparableImpl<decltype(t)>(); });
  });
}

namespace {

// TermRows (bounded_lm.h), found like ChannelSeparableImpl's answer: from the full per-entry
// Jet at 24 generic configurations.
template <typename Tag>
TermRows TermRowsImpl() {
  constexpr int P = Tag::template Of<double, double>::kParamCount;
  using Jet = ceres::Jet<double, P>;
  using M = typename Tag::template Of<Jet, double>;
  const std::vector<ParamSpec> table = M::Table();
  std::vector<int> row_of;
  for (int r = 0; r < static_cast<int>(table.size()); ++r) {
    for (int c = 0; c < table[r].size; ++c) row_of.push_back(r);
  }
  // Per term, the rows with a non-zero derivative at any configuration.
  std::array<std::vector<bool>, 3> reads;
  for (auto& v : reads) v.assign(table.size(), false);
  StructureRng rng(0x632be59bd9b4e019ull);
  for (int trial = 0; trial < 24; ++trial) {
    Jet p[P];
    GenericEntries(table, rng, p);
    const ShadingDots<double> d =
        ComputeShadingDots(Vec3d{0, 0, 1}, rng.Hemisphere(), rng.Hemisphere());
    const typename M::Params q = M::Load(p);
    const Rgb<Jet> diffuse = M::Diffuse(q, d), fresnel = M::Fresnel(q, d);
    const Jet lobe = M::Lobe(q, d);
    for (int e = 0; e < P; ++e) {
      for (int c = 0; c < 3; ++c) {
        if (diffuse[c].v[e] != 0.0) reads[0][row_of[e]] = true;
        if (fresnel[c].v[e] != 0.0) reads[1][row_of[e]] = true;
      }
      if (lobe.v[e] != 0.0) reads[2][row_of[e]] = true;
    }
  }
  TermRows out;
  out.single = true;
  int* slot[3] = {&out.diffuse, &out.fresnel, &out.lobe};
  for (int t = 0; t < 3; ++t) {
    for (int r = 0; r < static_cast<int>(table.size()); ++r) {
      if (!reads[t][r]) continue;
      if (*slot[t] >= 0) out.single = false;
      *slot[t] = r;
    }
  }
  return out;
}

}  // namespace

const TermRows& RowsOfTerms(ModelId model) {
  return VisitModel(model, [](auto tag) -> const TermRows& {
    return OncePerModel<decltype(tag)>([](auto t) { return TermRowsImpl<decltype(t)>(); });
  });
}

namespace {

// Which entries the model's radiance is affine in, jointly (variable projection, below): the
// second difference along each entry and the mixed difference of each pair vanish at 24
// generic configurations (as ChannelSeparableImpl's), to rounding. Greedy in table order, so of
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
  std::vector<Config> configs(24);
  for (Config& cfg : configs) {
    for (int i = 0; i < P; ++i) {
      const ParamSpec& row = *spec_of[i];
      const double lo = row.min, hi = std::min(row.max, row.min + 100.0);
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

}  // namespace

std::vector<bool> LinearEntries(ModelId model) {
  return VisitModel(model, [](auto tag) -> std::vector<bool> {
    return OncePerModel<decltype(tag)>([](auto t) { return LinearEntriesImpl<decltype(t)>(); });
  });
}

namespace {

// The parameters of model M loaded once per pass for the per-term shading below: each of the
// three terms gets its own copy with a one-slot Jet, the derivative along the single row it reads
// (TermRows; in the per-row layout that row's slot of the full Jet p). A term then costs about
// what it costs in doubles instead of carrying the full Jet's slots through every operation (the
// GGX lobe's D and V: two divisions and two square roots in Jet<4> before).
template <typename Tag, int K>
struct TermParams {
  using J1 = ceres::Jet<double, 1>;
  using M1 = typename Tag::template Of<J1, double>;
  typename M1::Params diffuse, fresnel, lobe;
  int diffuse_slot = -1, fresnel_slot = -1, lobe_slot = -1;

  TermParams(const ceres::Jet<double, K>* p, const TermRows& rows) {
    constexpr int P = M1::kParamCount;
    auto load = [&](int slot) {
      J1 p1[P];
      for (int i = 0; i < P; ++i) {
        p1[i] = J1(p[i].a);
        if (slot >= 0) p1[i].v[0] = p[i].v[slot];
      }
      return M1::Load(p1);
    };
    diffuse_slot = rows.diffuse;
    fresnel_slot = rows.fresnel;
    lobe_slot = rows.lobe;
    diffuse = load(diffuse_slot);
    fresnel = load(fresnel_slot);
    lobe = load(lobe_slot);
  }
};

// ShadeLoaded for TermParams: the same values (Reflected's sum in its order, so the cost is the
// double the twin gives), with each term's one derivative added into its slot of the full Jet;
// with kMixed also, per channel, the mixed derivative of the Fresnel-lobe product along both
// its rows, sum Fresnel_v Lobe_v e (ShiftLinear).
template <typename Tag, int K, bool kMixed>
[[gnu::flatten]] void ShadeTermwise(const TermParams<Tag, K>& t,
                                    const Rgb<ceres::Jet<double, K>>& ka, const Geometry& geo,
                                    int span, const ShadingPoint& point, int k,
                                    ceres::Jet<double, K>* out, double* mixed) {
  using M1 = typename TermParams<Tag, K>::M1;
  using Jet = ceres::Jet<double, K>;
  for (int c = 0; c < 3; ++c) out[c] = ka[c] * Jet(point.ambient[c]);
  if constexpr (kMixed) std::fill(mixed, mixed + 3, 0.0);
  auto add = [&](const ShadingDots<double>& d, const Vec3d& irradiance) {
    const auto diffuse = M1::Diffuse(t.diffuse, d);
    const auto fresnel = M1::Fresnel(t.fresnel, d);
    const auto lobe = M1::Lobe(t.lobe, d);
    for (int c = 0; c < 3; ++c) {
      const double e = irradiance[c];
      out[c].a += (diffuse[c].a * d.NoL + fresnel[c].a * lobe.a) * e;
      if (t.diffuse_slot >= 0) out[c].v[t.diffuse_slot] += diffuse[c].v[0] * d.NoL * e;
      if (t.fresnel_slot >= 0) out[c].v[t.fresnel_slot] += fresnel[c].v[0] * lobe.a * e;
      if (t.lobe_slot >= 0) out[c].v[t.lobe_slot] += fresnel[c].a * lobe.v[0] * e;
      if constexpr (kMixed) mixed[c] += fresnel[c].v[0] * lobe.v[0] * e;
    }
  };
  ForEachLitSample(geo, span, point, k, add);
}

// The Jacobian rows [v_0 .. v_{C-2}, r] of one group, gathered kRows at a time; each block is
// folded into the Gram matrix of its columns (sum v v^T, sum r v, sum r^2) by one fixed-size
// product B^T B, which vectorises, instead of 15 scalar updates per residual (ggx) whose
// accumulators spill out of the registers. A partial block is zero-padded (zero rows add
// nothing), so every block is summed in the same order whatever the chunk.
template <int C>
struct RowBlock {
  static constexpr int kRows = 64;
  Eigen::Matrix<double, kRows, C> rows;
  Eigen::Matrix<double, C, C> gram = Eigen::Matrix<double, C, C>::Zero();
  int count = 0;

  double* Next() {
    if (count == kRows) Flush();
    return &rows(count++, 0);
  }
  void Flush() {
    if (count == 0) return;
    if (count < kRows) rows.bottomRows(kRows - count).setZero();
    gram.noalias() += rows.transpose().lazyProduct(rows);
    count = 0;
  }
};

// Cost, gradient and Gauss-Newton matrix in one pass: AutoDiff over the parameters only (the
// geometry enters as plain numbers), each residual's Jacobian row folded into its group's Gram
// matrix at once (GroupGram), the groups then scattered onto the unknowns (ScatterGroups).
// kCompressed: one slot per table row (ChannelSeparable), else one per entry. The last slot is
// the log exposure. kTermwise (with kCompressed, where each term reads one row: TermRows): the
// terms are shaded with one-slot Jets (ShadeTermwise), and with L2 and a fixed exposure the rows
// carry the mixed column that lets ShiftLinear move the pass along the linear entries.
template <typename Tag, bool kCompressed, bool kTermwise>
Sums JacobianPass(const BoundedLmProblem& problem, const Geometry& geo,
                  const std::vector<Chunk>& chunks, const std::vector<double>& y, double e) {
  using ModelOfDouble = typename Tag::template Of<double, double>;
  constexpr int kParams = ModelOfDouble::kParamCount;
  constexpr int K = (kCompressed ? ModelOfDouble::kRowCount : kParams) + 1;
  constexpr int kGroups = kCompressed ? 3 : 1;
  constexpr int N = kParams + 1;  // Unknowns: the model's entries and the log exposure.
  using Jet = ceres::Jet<double, K>;
  using Model = typename Tag::template Of<Jet, double>;
  // Slot of each entry, and the unknown each (group, slot) stands for.
  int slot_of[kParams];
  int unknown_of[kGroups][K];
  int entry = 0, row = 0;
  for (const ParamSpec& spec : ModelOfDouble::Table()) {
    for (int c = 0; c < spec.size; ++c, ++entry) {
      slot_of[entry] = kCompressed ? row : entry;
      if (!kCompressed) {
        unknown_of[0][entry] = entry;
      } else if (spec.size == 1) {
        for (int g = 0; g < kGroups; ++g) unknown_of[g][row] = entry;
      } else {
        unknown_of[c][row] = entry;
      }
    }
    ++row;
  }
  for (int g = 0; g < kGroups; ++g) unknown_of[g][K - 1] = kParams;
  Jet yj[kParams], p[kParams];
  for (int i = 0; i < kParams; ++i) yj[i] = Jet(y[i], slot_of[i]);
  NaturalOfBox(*problem.param, yj, p);
  const Jet scale = problem.exposure_free ? exp(Jet(e, K - 1)) : Jet(std::exp(e));
  const typename Model::Params q = Model::Load(p);
  const Rgb<Jet> ka = Model::Ambient(q);
  static_assert(kCompressed || !kTermwise, "per-term Jets need one slot per row");
  const TermRows rows = kTermwise ? RowsOfTerms(problem.model) : TermRows{};
  const TermParams<Tag, K> terms(p, rows);
  // kActive: the slots that can be non-zero, the exposure's only when it is an unknown (a fixed
  // exposure's slot is zero in every residual: its sums are skipped, 10 of 15 per residual for
  // ggx). The residual is Compress(scale * radiance) - target; with L2 and a fixed exposure the
  // Jet is scaled by a plain number and not compressed.
  const bool plain = problem.loss == Loss::kL2 && !problem.exposure_free;
  Sums out;
  auto run = [&]<int kActive, bool kMixed>() {
    constexpr int C = kActive + (kMixed ? 1 : 0) + 1;  // The active slots, w, the residual.
    using Gram = Eigen::Matrix<double, C, C>;
    std::vector<std::array<Gram, kGroups>> partial(chunks.size());
    ForEachChunk(static_cast<int>(chunks.size()), problem.threads, [&](int ci) {
      const Chunk& c = chunks[ci];
      const PixelSpan& s = problem.spans[c.span];
      RowBlock<C> blocks[kGroups];
      for (int k = c.begin; k < c.begin + c.count; ++k) {
        Jet rgb[3];
        double mixed[3];
        if constexpr (kTermwise) {
          ShadeTermwise<Tag, K, kMixed>(terms, ka, geo, c.span, s.points[k], k, rgb, mixed);
        } else {
          ShadeLoaded<Model>(q, ka, geo, c.span, s.points[k], k, rgb);
        }
        for (int ch = 0; ch < 3; ++ch) {
          Jet r = plain ? rgb[ch] * scale.a : Compress(problem.loss, scale * rgb[ch]);
          r.a -= s.targets[3 * k + ch];
          RowBlock<C>& block = blocks[kCompressed ? ch : 0];
          // Column-major block: entry a of the row is kRows apart.
          double* q_row = block.Next();
          for (int a = 0; a < kActive; ++a) q_row[a * RowBlock<C>::kRows] = r.v[a];
          if constexpr (kMixed) q_row[kActive * RowBlock<C>::kRows] = mixed[ch] * scale.a;
          q_row[(C - 1) * RowBlock<C>::kRows] = r.a;
        }
      }
      for (int grp = 0; grp < kGroups; ++grp) {
        blocks[grp].Flush();
        partial[ci][grp] = blocks[grp].gram;
      }
    });
    // Partial sums in chunk order (thread-count independent).
    for (int grp = 0; grp < kGroups; ++grp) {
      Gram total = Gram::Zero();
      for (const auto& part : partial) total += part[grp];
      GroupGram& group = out.groups.emplace_back();
      group.unknown.assign(unknown_of[grp], unknown_of[grp] + kActive);
      group.mixed = kMixed;
      group.fresnel = rows.fresnel;
      group.lobe = rows.lobe;
      group.gram = total;
    }
  };
  if (problem.exposure_free) {
    run.template operator()<K, false>();
  } else if (kTermwise && plain) {
    run.template operator()<K - 1, kTermwise>();
  } else {
    run.template operator()<K - 1, false>();
  }
  ScatterGroups(N, &out);
  return out;
}

Sums Cost(const BoundedLmProblem& problem, const Geometry& geo, const std::vector<Chunk>& chunks,
          const std::vector<double>& y, double e) {
  return VisitModel(problem.model, [&](auto tag) {
    using M = typename decltype(tag)::template Of<double, double>;
    return CostPass<M>(problem, geo, chunks, y, e);
  });
}

Sums Jacobian(const BoundedLmProblem& problem, const Geometry& geo,
              const std::vector<Chunk>& chunks, const std::vector<double>& y, double e) {
  return VisitModel(problem.model, [&](auto tag) {
    using Tag = decltype(tag);
    if (problem.derivatives == JetLayout::kPerEntry || !ChannelSeparable(problem.model)) {
      return JacobianPass<Tag, false, false>(problem, geo, chunks, y, e);
    }
    if (problem.derivatives == JetLayout::kPerRow && RowsOfTerms(problem.model).single) {
      return JacobianPass<Tag, true, true>(problem, geo, chunks, y, e);
    }
    return JacobianPass<Tag, true, false>(problem, geo, chunks, y, e);
  });
}

// Trust region (Nocedal and Wright 2006, Algorithm 4.1; Moré 1978): a step is accepted when
// the actual reduction is at least kMinRatio of the predicted one; the radius shrinks to a
// quarter of the step below ratio 0.25 and doubles above 0.75. The first radius is
// kInitialRadiusFactor times |D x0| (Moré's factor 100: the first Gauss-Newton step is usually
// good, and a rejected one costs only one pass). kMinRatio is Ceres' min_relative_decrease:
// with Moré's 1e-4, aluminium-rim's first step (roughness 0.5 to its floor 0.01, ratio 1.7e-4)
// was accepted into a basin of kd = 1 and no f0 (cost 3.3e5 against 0.14).
constexpr double kMinRatio = 1e-3;
// Variable projection: a step whose actual reduction exceeds the predicted one by this factor
// is extended along its direction, at most kMaxExtension times (SolveBoundedLm).
constexpr double kExtendRatio = 1.2;
constexpr double kMaxExtension = 8.0;
constexpr double kInitialRadiusFactor = 100.0;

// Moré (1978, "The Levenberg-Marquardt algorithm: implementation and theory", Lecture Notes in
// Mathematics 630), sec. 2-5: the step minimises the Gauss-Newton model |J d + r|^2 subject to
// |D d| <= radius, D the column norms of J (non-decreasing over the iterations: the scaling that
// makes the method invariant to the units of each unknown; scipy's x_scale='jac' is the same
// idea). Inside the region the answer is the Gauss-Newton step itself (lambda = 0): unlike a
// damping that is always applied (Ceres' LM, D / radius added to J^T J), a valley whose
// curvature is tiny along one direction is crossed in one step, not at the pace of the damping.
// Else lambda > 0 with |D d(lambda)| = radius, found by bisection in log lambda between 0 and
// |D^-1 g| / radius (where |D d| <= radius is guaranteed); <= 12 unknowns, so each trial is a
// Cholesky of a 12 x 12 matrix.
bool TrustRegionStep(const Eigen::MatrixXd& h, const Eigen::VectorXd& g,
                     const Eigen::VectorXd& scale, double radius, Eigen::VectorXd* d,
                     double* lambda_out) {
  const int m = static_cast<int>(g.size());
  auto solve = [&](double lambda, Eigen::VectorXd* out) {
    Eigen::MatrixXd a = h;
    for (int i = 0; i < m; ++i) a(i, i) += lambda * scale[i] * scale[i];
    const Eigen::LLT<Eigen::MatrixXd> llt(a);
    if (llt.info() != Eigen::Success) return false;
    *out = llt.solve(-g);
    return out->allFinite();
  };
  auto norm = [&](const Eigen::VectorXd& v) { return scale.cwiseProduct(v).norm(); };
  *lambda_out = 0;
  if (solve(0.0, d) && norm(*d) <= 1.1 * radius) return true;
  double hi = scale.cwiseInverse().cwiseProduct(g).norm() / radius;
  if (!(hi > 0) || !std::isfinite(hi)) return false;
  Eigen::VectorXd best;
  if (!solve(hi, &best)) return false;
  double lo = 0;
  for (int it = 0; it < 60; ++it) {
    const double mid = lo > 0 ? std::sqrt(lo * hi) : hi * 1e-4;
    Eigen::VectorXd trial;
    if (!solve(mid, &trial) || norm(trial) > 1.1 * radius) {
      lo = mid;
      continue;
    }
    hi = mid;
    best = trial;
    if (norm(trial) >= 0.9 * radius) break;
    if (lo > 0 && hi / lo < 1.0 + 1e-6) break;
  }
  *d = best;
  *lambda_out = hi;
  return true;
}

// Entries within kActiveFraction of their box from a bound, with the gradient pointing out of
// it, are held (Bertsekas 1982's eps-active set: an entry creeping towards its bound is put on it
// instead of being approached geometrically). 1e-6 of the box is below every tolerance the fits
// are judged by (1% of a parameter).
constexpr double kActiveFraction = 1e-6;

}  // namespace

std::vector<double> BoxOfInternal(const Parametrization& param, const std::vector<double>& u) {
  std::vector<double> y(u.size());
  for (int i = 0; i < param.size(); ++i) {
    const EntryMap& e = param.entry(i);
    y[i] = e.lower + 0.5 * (e.upper - e.lower) * (std::sin(u[i]) + 1.0);
    y[i] = std::clamp(y[i], e.lower, e.upper);
    if (e.log && !InBoxLog(param, i)) y[i] = std::exp(y[i]);
  }
  return y;
}

std::vector<double> InternalOfBox(const Parametrization& param, const std::vector<double>& y) {
  std::vector<double> u(y.size());
  for (int i = 0; i < param.size(); ++i) {
    const EntryMap& e = param.entry(i);
    const double box = e.log && !InBoxLog(param, i) ? std::log(y[i]) : y[i];
    u[i] = Parametrization::FromBox(e, box);
  }
  return u;
}

double FractionDerivative(const Parametrization& param, int i, double u) {
  const EntryMap& e = param.entry(i);
  if (e.fixed) return 0.0;
  const double dy = 0.5 * (e.upper - e.lower);
  if (!e.log || InBoxLog(param, i)) return dy;
  const double y = std::clamp(e.lower + 0.5 * (e.upper - e.lower) * (std::sin(u) + 1.0),
                              e.lower, e.upper);
  return std::exp(y) * dy;  // The LM works on p = exp(y) here.
}

double BoxDerivative(const Parametrization& param, int i, double u) {
  return FractionDerivative(param, i, u) * std::cos(u);
}

double BoundedLmCost(const BoundedLmProblem& problem, const std::vector<double>& y, double e) {
  const std::vector<Chunk> chunks = Chunks(problem);
  const Sums s = Cost(problem, *GeometryOf(problem, chunks), chunks, y, e);
  return s.finite ? s.cost : std::numeric_limits<double>::quiet_NaN();
}

double BoundedLmNormalEquations(const BoundedLmProblem& problem, const std::vector<double>& y,
                                double e, std::vector<double>* g, std::vector<double>* h) {
  const std::vector<Chunk> chunks = Chunks(problem);
  Sums s = Jacobian(problem, *GeometryOf(problem, chunks), chunks, y, e);
  *g = std::move(s.g);
  *h = std::move(s.h);
  return s.finite ? s.cost : std::numeric_limits<double>::quiet_NaN();
}

std::vector<bool> ProjectedEntries(const BoundedLmProblem& problem) {
  const Parametrization& param = *problem.param;
  const int n = param.size();
  std::vector<bool> linear(n + 1, false);
  if (!ProjectionApplies(problem.loss, problem.exposure_free)) return linear;
  const std::vector<bool> model_linear = LinearEntries(problem.model);
  bool any_linear = false, any_nonlinear = false;
  for (int i = 0; i < n; ++i) {
    if (param.entry(i).fixed) continue;
    linear[i] = model_linear[i] && !InBoxLog(param, i);
    (linear[i] ? any_linear : any_nonlinear) = true;
  }
  if (!any_linear || !any_nonlinear) std::fill(linear.begin(), linear.end(), false);
  return linear;
}

bool BoundedLmShiftedNormalEquations(const BoundedLmProblem& problem, const std::vector<double>& y,
                                     double e, const std::vector<double>& delta, double* cost,
                                     std::vector<double>* g, std::vector<double>* h) {
  const std::vector<Chunk> chunks = Chunks(problem);
  Sums s = Jacobian(problem, *GeometryOf(problem, chunks), chunks, y, e);
  if (!ShiftLinear(delta, &s)) return false;
  *cost = s.cost;
  *g = std::move(s.g);
  *h = std::move(s.h);
  return true;
}

namespace {

// Pseudo-inverse solve of a small symmetric positive semi-definite system: directions with
// eigenvalue below 1e-12 of the largest are left out (a linear entry the image does not see).
Eigen::VectorXd SolvePsd(const Eigen::MatrixXd& a, const Eigen::VectorXd& b) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(a);
  const Eigen::VectorXd& lambda = eig.eigenvalues();
  const double max_lambda = lambda.size() > 0 ? lambda.maxCoeff() : 0.0;
  Eigen::VectorXd coeff = eig.eigenvectors().transpose() * b;
  for (int i = 0; i < coeff.size(); ++i) {
    coeff[i] = max_lambda > 0 && lambda[i] > 1e-12 * max_lambda ? coeff[i] / lambda[i] : 0.0;
  }
  return eig.eigenvectors() * coeff;
}

// min over z in [lo, hi] of q(z) = g.(z - z0) + 0.5 (z - z0)' H (z - z0), H positive
// semi-definite, from z0 inside the box: projected Newton with an Armijo search along the
// projection arc (Bertsekas 1982; for a quadratic the Newton step on the free entries is exact,
// so this ends after one step per change of the active set). Returns z.
Eigen::VectorXd BoxQp(const Eigen::MatrixXd& h, const Eigen::VectorXd& g, const Eigen::VectorXd& z0,
                      const Eigen::VectorXd& lo, const Eigen::VectorXd& hi) {
  const int m = static_cast<int>(g.size());
  auto q = [&](const Eigen::VectorXd& z) {
    const Eigen::VectorXd d = z - z0;
    return g.dot(d) + 0.5 * d.dot(h * d);
  };
  Eigen::VectorXd z = z0;
  for (int it = 0; it < 4 * m + 8; ++it) {
    const Eigen::VectorXd grad = g + h * (z - z0);
    std::vector<int> free;
    for (int i = 0; i < m; ++i) {
      const bool out_low = z[i] <= lo[i] && grad[i] > 0;
      const bool out_high = z[i] >= hi[i] && grad[i] < 0;
      if (!out_low && !out_high) free.push_back(i);
    }
    if (free.empty()) break;
    const int f = static_cast<int>(free.size());
    Eigen::MatrixXd hf(f, f);
    Eigen::VectorXd gf(f);
    for (int a = 0; a < f; ++a) {
      gf[a] = grad[free[a]];
      for (int b = 0; b < f; ++b) hf(a, b) = h(free[a], free[b]);
    }
    const Eigen::VectorXd step = SolvePsd(hf, -gf);
    const double q0 = q(z);
    bool moved = false;
    for (double t = 1.0; t > 1e-10; t *= 0.5) {
      Eigen::VectorXd trial = z;
      for (int a = 0; a < f; ++a) {
        const int i = free[a];
        trial[i] = std::clamp(z[i] + t * step[a], lo[i], hi[i]);
      }
      if (q(trial) <= q0 + 1e-4 * grad.dot(trial - z)) {
        moved = (trial - z).lpNorm<Eigen::Infinity>() > 0;
        z = trial;
        break;
      }
    }
    if (!moved) break;
  }
  return z;
}

}  // namespace

BoundedLmSummary SolveBoundedLm(const BoundedLmProblem& problem, const BoundedLmOptions& options,
                                std::vector<double>* y_io, double* e_io) {
  const Parametrization& param = *problem.param;
  const int n = param.size();
  const int N = n + 1;
  const std::vector<Chunk> chunks = Chunks(problem);
  const std::shared_ptr<const Geometry> geometry = GeometryOf(problem, chunks);
  const Geometry& geo = *geometry;
  BoundedLmSummary summary;

  // x = [y, e]; box of every unknown (the exposure is unbounded).
  std::vector<double> x(*y_io), lo(N), hi(N);
  x.push_back(*e_io);
  std::vector<bool> unknown(N, false);
  for (int i = 0; i < n; ++i) {
    BoxOf(param, i, &lo[i], &hi[i]);
    unknown[i] = !param.entry(i).fixed;
    if (unknown[i]) x[i] = std::clamp(x[i], lo[i], hi[i]);
  }
  lo[n] = -std::numeric_limits<double>::infinity();
  hi[n] = std::numeric_limits<double>::infinity();
  unknown[n] = problem.exposure_free;

  // Variable projection (Golub and Pereyra 1973, "The differentiation of pseudo-inverses and
  // nonlinear least squares problems whose variables separate", SIAM J. Numer. Anal. 10(2);
  // with Kaufman's 1975 approximation of the reduced Jacobian, BIT 15). With the L2 loss and a
  // fixed exposure the image is affine in the linear entries (LinearEntries: kd and f0 of ggx,
  // kd and ks of the Blinn-Phong models), so for given nonlinear entries (roughness, shininess)
  // their best values are a box-constrained linear least-squares problem whose normal equations
  // are the Jacobian pass's own rows of J^T J and J^T r, solved exactly (BoxQp). The trust
  // region then works on the nonlinear entries alone, with the Schur complement of the linear
  // block (the Gauss-Newton model of the cost with the linear entries re-optimised), and every
  // trial point is re-projected before it is judged. The valley that a joint step follows at
  // ~1% per step when a highlight and the diffuse trade off (black-glossy-rim: kd and f0 falling
  // together by 10x while roughness moves 10%) is then a one-dimensional problem.
  const std::vector<bool> linear = ProjectedEntries(problem);
  const bool varpro = std::find(linear.begin(), linear.end(), true) != linear.end();
  std::vector<int> linear_index;
  for (int i = 0; i < N; ++i) {
    if (linear[i]) linear_index.push_back(i);
  }
  // Moves the linear entries of xv to their exact optimum for the other entries, from the
  // pass at xv, and the pass with them (ShiftLinear); else updates only the pass's cost (exact:
  // the cost is quadratic in them). Returns whether the pass is stale: its g and h belong to the
  // old point, and a fresh pass is needed there.
  auto project = [&](Sums* pass, std::vector<double>* xv) {
    const int l = static_cast<int>(linear_index.size());
    Eigen::MatrixXd h(l, l);
    Eigen::VectorXd g(l), z0(l), zl(l), zh(l);
    for (int a = 0; a < l; ++a) {
      const int i = linear_index[a];
      g[a] = pass->g[i];
      z0[a] = (*xv)[i];
      zl[a] = lo[i];
      zh[a] = hi[i];
      for (int b = 0; b < l; ++b) h(a, b) = pass->h[i * N + linear_index[b]];
    }
    const Eigen::VectorXd z = BoxQp(h, g, z0, zl, zh);
    const Eigen::VectorXd d = z - z0;
    const double change = g.dot(d) + 0.5 * d.dot(h * d);
    if (!(change < 0)) return false;
    std::vector<double> delta(N, 0.0);
    for (int a = 0; a < l; ++a) {
      (*xv)[linear_index[a]] = z[a];
      delta[linear_index[a]] = d[a];
    }
    if (ShiftLinear(delta, pass)) return false;
    pass->cost += change;
    return true;
  };

  auto split = [&](const std::vector<double>& v) {
    return std::vector<double>(v.begin(), v.begin() + n);
  };
  Sums at = Jacobian(problem, geo, chunks, split(x), x[n]);
  ++summary.jacobian_evaluations;
  summary.initial_cost = summary.final_cost = at.cost;
  if (!at.finite) {
    summary.failed = true;
    summary.message = "non-finite cost at the start point";
    return summary;
  }
  if (varpro && project(&at, &x)) {
    at = Jacobian(problem, geo, chunks, split(x), x[n]);
    ++summary.jacobian_evaluations;
    if (!at.finite) {
      summary.message = "non-finite Jacobian";
      return summary;
    }
  }

  const bool trace = std::getenv("SHADEFIT_FIT_TRACE") != nullptr;
  // Moré's scaling: D_i = max over the iterations of |column i of J| (1 where it is 0).
  std::vector<double> scale(N, 0.0);
  auto update_scale = [&] {
    for (int i = 0; i < N; ++i) scale[i] = std::max(scale[i], std::sqrt(at.h[i * N + i]));
  };
  auto scale_of = [&](int i) { return scale[i] > 0 ? scale[i] : 1.0; };
  update_scale();
  double radius = 0;
  for (int i = 0; i < N; ++i) {
    if (unknown[i] && !linear[i]) radius += std::pow(scale_of(i) * x[i], 2);
  }
  radius = std::sqrt(radius);
  radius = kInitialRadiusFactor * (radius > 0 ? radius : 1.0);
  if (options.initial_radius > 0) radius = options.initial_radius;
  summary.message = "maximum iterations reached";
  while (summary.iterations < options.max_iterations) {
    // Binding set and projected gradient (the first-order optimality measure with bounds).
    std::vector<int> varying, held_linear;
    double projected_gradient = 0;
    for (int i = 0; i < N; ++i) {
      if (!unknown[i]) continue;
      const double width = hi[i] - lo[i];
      const double eps = std::isfinite(width) ? kActiveFraction * width : 0.0;
      const double moved = std::clamp(x[i] - at.g[i], lo[i], hi[i]) - x[i];
      projected_gradient = std::max(projected_gradient, std::abs(moved));
      const bool out_low = x[i] <= lo[i] + eps && at.g[i] > 0;
      const bool out_high = x[i] >= hi[i] - eps && at.g[i] < 0;
      if (!out_low && !out_high) (linear[i] ? held_linear : varying).push_back(i);
    }
    if (projected_gradient <= options.gradient_tolerance) {
      summary.converged = true;
      summary.message = "gradient tolerance reached";
      break;
    }
    if (varying.empty()) {
      // Every unknown is held on a bound with its gradient pointing outwards (with variable
      // projection: every nonlinear one, the linear ones at their optimum): a KKT point.
      summary.converged = true;
      summary.message = "every unknown on a bound";
      break;
    }
    const int m = static_cast<int>(varying.size());
    Eigen::MatrixXd h(m, m);
    Eigen::VectorXd g(m), d_scale(m);
    double x_norm = 0;
    for (int a = 0; a < m; ++a) {
      g[a] = at.g[varying[a]];
      d_scale[a] = scale_of(varying[a]);
      x_norm += std::pow(d_scale[a] * x[varying[a]], 2);
      for (int b = 0; b < m; ++b) h(a, b) = at.h[varying[a] * N + varying[b]];
    }
    if (!held_linear.empty()) {
      // The linear entries re-optimised along the step: the Schur complement of their block
      // (Kaufman's reduced Gauss-Newton matrix), g likewise.
      const int l = static_cast<int>(held_linear.size());
      Eigen::MatrixXd hll(l, l), hln(l, m);
      Eigen::VectorXd gl(l);
      for (int a = 0; a < l; ++a) {
        gl[a] = at.g[held_linear[a]];
        for (int b = 0; b < l; ++b) hll(a, b) = at.h[held_linear[a] * N + held_linear[b]];
        for (int b = 0; b < m; ++b) hln(a, b) = at.h[held_linear[a] * N + varying[b]];
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(hll);
      const double max_lambda = eig.eigenvalues().maxCoeff();
      Eigen::VectorXd inverse(l);
      for (int a = 0; a < l; ++a) {
        const double lambda = eig.eigenvalues()[a];
        inverse[a] = max_lambda > 0 && lambda > 1e-12 * max_lambda ? 1.0 / lambda : 0.0;
      }
      const Eigen::MatrixXd pinv =
          eig.eigenvectors() * inverse.asDiagonal() * eig.eigenvectors().transpose();
      h -= hln.transpose() * pinv * hln;
      g -= hln.transpose() * (pinv * gl);
      h = 0.5 * (h + h.transpose());
    }
    x_norm = std::sqrt(x_norm);
    if (radius <= options.parameter_tolerance * (x_norm + options.parameter_tolerance)) {
      summary.converged = true;
      summary.message = "trust region below the parameter tolerance";
      break;
    }
    ++summary.iterations;
    Eigen::VectorXd d;
    double lambda = 0;
    if (!TrustRegionStep(h, g, d_scale, radius, &d, &lambda)) {
      radius *= 0.25;
      continue;
    }
    // Projected trial point (the reduced step, then the box); the model's prediction is taken
    // at the projected step.
    std::vector<double> trial = x;
    Eigen::VectorXd step(m);
    for (int a = 0; a < m; ++a) {
      const int i = varying[a];
      trial[i] = std::clamp(x[i] + d[a], lo[i], hi[i]);
      step[a] = trial[i] - x[i];
    }
    const double step_norm = d_scale.cwiseProduct(step).norm();
    if (step_norm <= options.parameter_tolerance * (x_norm + options.parameter_tolerance)) {
      summary.converged = true;
      summary.message = "parameter tolerance reached";
      break;
    }
    const double predicted = -(g.dot(step) + 0.5 * step.dot(h * step));
    if (lambda == 0 && predicted >= 0 && predicted <= options.function_tolerance * at.cost) {
      // The Gauss-Newton step itself (inside the region) is predicted to gain less than the
      // function tolerance: the accepted-step test below would stop after evaluating it (one
      // more pass, two with variable projection, to confirm what the model says). MINPACK's
      // lmder stops on the same predicted relative reduction (Moré, Garbow and Hillstrom 1980,
      // "User guide for MINPACK-1", ANL-80-74, sec. 2.3: ftol, both actual and predicted; the
      // actual one is that of the step that led here).
      summary.converged = true;
      summary.message = "predicted reduction below the function tolerance";
      break;
    }
    // The trial's cost; with variable projection after re-optimising the linear entries there,
    // which needs that point's normal equations (a Jacobian pass, kept unless it went stale).
    Sums trial_pass;
    bool trial_stale = false;
    if (varpro) {
      trial_pass = Jacobian(problem, geo, chunks, split(trial), trial[n]);
      ++summary.jacobian_evaluations;
      if (trial_pass.finite) trial_stale = project(&trial_pass, &trial);
    } else {
      trial_pass = Cost(problem, geo, chunks, split(trial), trial[n]);
      ++summary.residual_evaluations;
    }
    double actual = at.cost - trial_pass.cost;
    const double ratio = predicted > 0 ? actual / predicted : -1.0;
    double step_taken = step_norm;
    if (varpro && trial_pass.finite && ratio > kExtendRatio) {
      // The reduction beat the model's by kExtendRatio or more: the reduced Gauss-Newton matrix
      // overstates the curvature (a large-residual fit, such as GGX to a measured material,
      // where J^T J misses the residuals' own curvature), and full steps converge only
      // linearly (alum-bronze under the key light: ratio 1.65 at every one of 49 steps). The
      // parabola through the cost at 0 and 1 with the slope g.step at 0 (the projected cost's
      // derivative: the linear entries sit at their optimum) puts its minimum at t > 1; the
      // step is extended there once, and kept if it is lower still (a quadratic-interpolation
      // line search along the step, Nocedal and Wright 2006, sec. 3.5).
      const double slope = g.dot(step);
      const double curvature = trial_pass.cost - at.cost - slope;
      if (slope < 0 && curvature > 0) {
        const double t = std::min(kMaxExtension, -slope / (2 * curvature));
        if (t > 1.5) {
          std::vector<double> longer = x;
          for (int a = 0; a < m; ++a) {
            const int i = varying[a];
            longer[i] = std::clamp(x[i] + t * step[a], lo[i], hi[i]);
          }
          Sums longer_pass = Jacobian(problem, geo, chunks, split(longer), longer[n]);
          ++summary.jacobian_evaluations;
          if (longer_pass.finite) {
            const bool longer_stale = project(&longer_pass, &longer);
            if (longer_pass.cost < trial_pass.cost) {
              Eigen::VectorXd taken(m);
              for (int a = 0; a < m; ++a) taken[a] = longer[varying[a]] - x[varying[a]];
              step_taken = d_scale.cwiseProduct(taken).norm();
              trial = std::move(longer);
              trial_pass = std::move(longer_pass);
              trial_stale = longer_stale;
              actual = at.cost - trial_pass.cost;
            }
          }
        }
      }
    }
    if (trace) {
      // SHADEFIT_FIT_TRACE=1: one line per step (debugging aid, as the Ceres path's table).
      fmt::print("lm {:3d} cost {:.9g} trial {:.9g} ratio {:.3g} radius {:.3g} lambda {:.3g} "
                 "free {} |g| {:.3g}:",
                 summary.iterations, at.cost, trial_pass.cost, ratio, radius, lambda, m,
                 projected_gradient);
      for (int i = 0; i < N; ++i) {
        fmt::print(" {:.4g}", i < n && InBoxLog(param, i) ? std::exp(trial[i]) : trial[i]);
      }
      fmt::print("\n");
    }
    if (!trial_pass.finite || ratio < 0.25) {
      radius = 0.25 * std::min(radius, step_norm);
    } else if (ratio > 0.75) {
      radius = std::max(radius, 2.0 * step_taken);
    }
    if (trial_pass.finite && actual > 0 && ratio > kMinRatio) {
      x = trial;
      const double previous = at.cost;
      if (varpro && !trial_stale) {
        at = std::move(trial_pass);
      } else {
        at = Jacobian(problem, geo, chunks, split(x), x[n]);
        ++summary.jacobian_evaluations;
      }
      if (!at.finite) {
        summary.message = "non-finite Jacobian";
        break;
      }
      update_scale();
      if (previous - at.cost <= options.function_tolerance * previous) {
        summary.converged = true;
        summary.message = "function tolerance reached";
        break;
      }
    }
  }
  summary.final_cost = at.cost;
  std::copy(x.begin(), x.begin() + n, y_io->begin());
  *e_io = x[n];
  summary.final_radius = radius;
  return summary;
}

}  // namespace shadefit::fit::internal
