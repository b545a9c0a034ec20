// What the bounded LM reads of a model's structure (internal to fit/): whether its colour
// channels stay apart, which table row each of its three terms reads, and which entries its
// radiance is affine in. Found once per model by probing the C++ twin (models.h) at fixed
// generic configurations, not declared by hand, so a new model gets the right Jacobian pass and
// variable projection without a line here (tests/fit/model_structure_test.cpp holds the answers
// against the formulas).
#pragma once

#include <vector>

#include "shadefit/render/models.h"

namespace shadefit::fit::internal {

// The model's reflected radiance per unit light, Reflect's sum (models.h) in its order:
// Diffuse n.l + Fresnel Lobe.
template <typename M, typename T>
Rgb<T> Reflected(const typename M::Params& q, const ShadingDots<double>& d) {
  return M::Diffuse(q, d) * T(d.NoL) + M::Fresnel(q, d) * M::Lobe(q, d);
}

// Whether every output channel of the model depends on the same channel of its colour rows
// only (kd.r acts on red alone, ...): true for every model that does not mix its colours.
bool ChannelSeparable(ModelId model);

// The table row each of the model's three terms (Diffuse, Fresnel, Lobe; models.h) reads, -1
// for none; `single` is false when one of them reads two rows or more. Where every term reads
// one row at most (ggx: kd, f0, roughness), the Jacobian pass shades each term with a one-slot
// Jet and adds its derivative into that row's slot.
struct TermRows {
  bool single = false;
  int diffuse = -1, fresnel = -1, lobe = -1;
};
const TermRows& RowsOfTerms(ModelId model);

// Per flattened entry: whether the model's radiance is affine in it, jointly with the other
// entries marked (ggx: kd and f0; not roughness).
std::vector<bool> LinearEntries(ModelId model);

// Whether the radiance is moreover zero when those entries are (linear, not only affine, in
// them): lambert, phong, the Blinn-Phongs, ward, lafortune; not ggx, whose Schlick Fresnel
// f0 + (1 - f0)(1 - l.h)^5 is not zero at f0 = 0.
bool HomogeneousInLinearEntries(ModelId model);

// Per flattened entry: whether only the ambient term reads it (the classic models' ka). Under
// references without ambient light it has no effect on any pixel.
std::vector<bool> AmbientOnlyEntries(ModelId model);

}  // namespace shadefit::fit::internal
