// Implementation of Reflect() for every model; included by models.h. The parameter layouts here
// must match the tables in render/src/models.cpp and the GLSL in render/shaders/models.glsl.
#pragma once

namespace shadefit {
namespace internal {

// Dot products of one shading configuration, in the geometry scalar G.
template <typename G>
struct Dots {
  G NoL, NoV, NoH, LoH, one_minus_NoH2;
};

template <typename G>
Dots<G> ComputeDots(const Vec3<G>& n, const Vec3<G>& l, const Vec3<G>& v) {
  Dots<G> d;
  d.NoL = Dot(n, l);
  d.NoV = Dot(n, v);
  // Callers return early when NoL or NoV <= 0, so l + v != 0 here.
  const Vec3<G> h = Normalize(l + v);
  d.NoH = Dot(n, h);
  d.LoH = Dot(l, h);
  const Vec3<G> nxh = Cross(n, h);
  d.one_minus_NoH2 = Dot(nxh, nxh);
  return d;
}

// Specular microfacet lobe D * V (without Fresnel) for the given distribution and visibility.
template <typename T, typename G>
T SpecularDV(Distribution dist, Visibility vis, const Dots<G>& d, const T& alpha) {
  const T D = dist == Distribution::kGgx ? D_GGX(d.NoH, d.one_minus_NoH2, alpha)
                                          : D_Beckmann(d.NoH, d.one_minus_NoH2, alpha);
  T V;
  switch (vis) {
    case Visibility::kSmithGgxCorrelated: V = V_SmithGGXCorrelated(d.NoV, d.NoL, alpha); break;
    case Visibility::kSmithGgxSeparable: V = V_SmithGGXSeparable(d.NoV, d.NoL, alpha); break;
    default: V = V_SmithBeckmannSeparable(d.NoV, d.NoL, alpha); break;
  }
  return D * V;
}

// kd * Fd + F(f0) * D * V, all times NoL: the raw GGX family (kd, f0, roughness).
template <typename T, typename G>
void ReflectRawMicrofacet(Distribution dist, Visibility vis, bool burley, const T* p,
                          const Dots<G>& d, T* out) {
  const T& roughness = p[6];
  const T alpha = roughness * roughness;
  const T dv = SpecularDV(dist, vis, d, alpha);
  const T fd = burley ? Fd_Burley(d.NoV, d.NoL, d.LoH, roughness) : Fd_Lambert<T>();
  for (int c = 0; c < 3; ++c) {
    out[c] = (p[c] * fd + F_Schlick(p[3 + c], d.LoH) * dv) * T(d.NoL);
  }
}

}  // namespace internal

template <typename T, typename G>
void Reflect(ModelId id, const T* p, const Vec3<G>& n, const Vec3<G>& l, const Vec3<G>& v,
             T* out) {
  using std::pow;
  using namespace internal;
  out[0] = out[1] = out[2] = T(0);
  const G NoL = Dot(n, l);
  const G NoV = Dot(n, v);
  if (!(NoL > G(0)) || !(NoV > G(0))) return;

  switch (id) {
    case ModelId::kLambert: {
      for (int c = 0; c < 3; ++c) out[c] = p[c] * T(kInvPi) * T(NoL);
      return;
    }
    case ModelId::kPhong:
    case ModelId::kBlinnPhong: {
      // Layout: ka[0..2] kd[3..5] ks[6..8] shininess[9].
      G cos_lobe;
      if (id == ModelId::kPhong) {
        // Phong 1975: (r . v)^n with r the mirror of l about n.
        const Vec3<G> r = n * (G(2) * NoL) - l;
        cos_lobe = Dot(r, v);
      } else {
        // Blinn 1977: (n . h)^n with h the half vector.
        cos_lobe = Dot(n, Normalize(l + v));
      }
      const T spec = cos_lobe > G(0) ? pow(T(cos_lobe), p[9]) : T(0);
      for (int c = 0; c < 3; ++c) out[c] = p[3 + c] * T(NoL) + p[6 + c] * spec;
      return;
    }
    case ModelId::kBlinnPhongNormalized: {
      // Layout: kd[0..2] ks[3..5] shininess[6]. (n + 8) / (8 pi) is the approximate
      // normalisation of Blinn-Phong with the cosine factor (Akenine-Moller, Haines, Hoffman,
      // "Real-Time Rendering" 3rd ed., eq. 7.49; exact for n -> infinity, see docs/models.md).
      const G NoH = Dot(n, Normalize(l + v));
      const T spec = NoH > G(0) ? pow(T(NoH), p[6]) : T(0);
      const T norm = (p[6] + T(8)) / T(8.0 * kPi);
      for (int c = 0; c < 3; ++c) {
        out[c] = (p[c] * T(kInvPi) + p[3 + c] * norm * spec) * T(NoL);
      }
      return;
    }
    case ModelId::kGgx:
      ReflectRawMicrofacet(Distribution::kGgx, Visibility::kSmithGgxCorrelated, false, p,
                           ComputeDots(n, l, v), out);
      return;
    case ModelId::kGgxSeparable:
      ReflectRawMicrofacet(Distribution::kGgx, Visibility::kSmithGgxSeparable, false, p,
                           ComputeDots(n, l, v), out);
      return;
    case ModelId::kGgxBurley:
      ReflectRawMicrofacet(Distribution::kGgx, Visibility::kSmithGgxCorrelated, true, p,
                           ComputeDots(n, l, v), out);
      return;
    case ModelId::kBeckmann:
      ReflectRawMicrofacet(Distribution::kBeckmann, Visibility::kSmithBeckmannSeparable, false,
                           p, ComputeDots(n, l, v), out);
      return;
    case ModelId::kGgxMetallic: {
      // Layout: base_color[0..2] metallic[3] roughness[4] f0_dielectric[5].
      const Dots<G> d = ComputeDots(n, l, v);
      const T& metallic = p[3];
      const T alpha = p[4] * p[4];
      const T dv = SpecularDV(Distribution::kGgx, Visibility::kSmithGgxCorrelated, d, alpha);
      for (int c = 0; c < 3; ++c) {
        const T kd = p[c] * (T(1) - metallic);
        const T f0 = p[5] * (T(1) - metallic) + p[c] * metallic;
        out[c] = (kd * T(kInvPi) + F_Schlick(f0, d.LoH) * dv) * T(d.NoL);
      }
      return;
    }
    case ModelId::kGgxDielectric: {
      // Layout: kd[0..2] ior[3] roughness[4]. Walter et al. 2007 evaluate F at i . m = LoH.
      const Dots<G> d = ComputeDots(n, l, v);
      const T alpha = p[4] * p[4];
      const T spec = F_Dielectric(d.LoH, p[3]) *
                     SpecularDV(Distribution::kGgx, Visibility::kSmithGgxCorrelated, d, alpha);
      for (int c = 0; c < 3; ++c) out[c] = (p[c] * T(kInvPi) + spec) * T(d.NoL);
      return;
    }
    case ModelId::kGgxConductor: {
      // Layout: eta[0..2] k[3..5] roughness[6]. Metals have no diffuse term.
      const Dots<G> d = ComputeDots(n, l, v);
      const T alpha = p[6] * p[6];
      const T dv = SpecularDV(Distribution::kGgx, Visibility::kSmithGgxCorrelated, d, alpha);
      for (int c = 0; c < 3; ++c) out[c] = F_Conductor(d.LoH, p[c], p[3 + c]) * dv * T(d.NoL);
      return;
    }
    case ModelId::kCyclesPrincipled: {
      // Layout: base_color[0..2] metallic[3] specular[4] roughness[5]. Cycles 3.4
      // (kernel/closure/bsdf_principled_diffuse.h, bsdf_microfacet.h, svm_closure.h):
      // alpha = roughness^2, separable Smith G, Burley diffuse weighted by base * (1 - metallic)
      // and simply added, Fresnel interpolated from cspec0 to 1 along the dielectric curve of
      // ior = 2 / (1 - sqrt(0.08 specular)) - 1 (specular tint 0).
      using std::sqrt;
      const Dots<G> d = ComputeDots(n, l, v);
      const T& metallic = p[3];
      const T& specular = p[4];
      const T& roughness = p[5];
      const T alpha = roughness * roughness;
      // sqrt argument bounded away from 0: specular = 0 would mean ior 1 and F0 = 0, where the
      // remap divides by (1 - F0) anyway; 1e-6 keeps the Jet derivative finite.
      const T s = T(0.08) * specular + T(1e-6);
      const T ior = T(2) / (T(1) - sqrt(s)) - T(1);
      const T dv = SpecularDV(Distribution::kGgx, Visibility::kSmithGgxSeparable, d, alpha);
      const T fd = Fd_Burley(d.NoV, d.NoL, d.LoH, roughness);
      for (int c = 0; c < 3; ++c) {
        const T cspec0 = T(0.08) * specular * (T(1) - metallic) + p[c] * metallic;
        const T F = F_CyclesPrincipled(cspec0, ior, d.LoH);
        out[c] = (p[c] * (T(1) - metallic) * fd + F * dv) * T(d.NoL);
      }
      return;
    }
  }
}

}  // namespace shadefit
