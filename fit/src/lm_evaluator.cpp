#include "lm_evaluator.h"

#include <ceres/jet.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "box_coordinates.h"
#include "model_structure.h"

namespace shadefit::fit::internal {
namespace {

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

template <typename T>
T Compress(Loss loss, const T& x) {
  return CompressRadiance(loss, x);
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

// The slot of each of the model's entries in the pass's Jets, and the unknown each (group, slot)
// stands for; the last slot is the log exposure. kCompressed: one slot per table row, a colour
// row's channels in groups 0-2; else one slot per entry, in one group.
template <typename ModelOfDouble, bool kCompressed, int kGroups, int K>
void MapSlots(int (&slot_of)[ModelOfDouble::kParamCount], int (&unknown_of)[kGroups][K]) {
  constexpr int kParams = ModelOfDouble::kParamCount;
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
}

// Appends each group's Gram matrix to `out`, its chunks' partial sums added in chunk order
// (thread-count independent); `active` slots stand for the unknowns `unknown_of` names.
template <int C, int kGroups, int K>
void AddGroups(const std::vector<std::array<Eigen::Matrix<double, C, C>, kGroups>>& partial,
               const int (&unknown_of)[kGroups][K], int active, bool mixed, const TermRows& rows,
               Sums* out) {
  using Gram = Eigen::Matrix<double, C, C>;
  for (int grp = 0; grp < kGroups; ++grp) {
    Gram total = Gram::Zero();
    for (const auto& part : partial) total += part[grp];
    GroupGram& group = out->groups.emplace_back();
    group.unknown.assign(unknown_of[grp], unknown_of[grp] + active);
    group.mixed = mixed;
    group.fresnel = rows.fresnel;
    group.lobe = rows.lobe;
    group.gram = total;
  }
}

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
  MapSlots<ModelOfDouble, kCompressed>(slot_of, unknown_of);
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
    AddGroups<C, kGroups, K>(partial, unknown_of, kActive, kMixed, rows, &out);
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

}  // namespace

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

}  // namespace shadefit::fit::internal
