// GLSL twins of the terms in render/include/shadefit/render/brdf.h (same names, same sources;
// see there for citations). tests/render/glsl_twin_test.cpp holds the two copies together.

const float kPi = 3.14159265358979;
const float kInvPi = 0.31830988618379;
const float kMinAlpha = 1e-4;

float Pow5(float x) { float x2 = x * x; return x2 * x2 * x; }

float D_GGX(float NoH, float one_minus_NoH2, float alpha) {
  float a = max(alpha, kMinAlpha);
  float a2 = a * a;
  float d = one_minus_NoH2 + NoH * NoH * a2;
  return a2 / (kPi * d * d);
}

float D_Beckmann(float NoH, float one_minus_NoH2, float alpha) {
  float a = max(alpha, kMinAlpha);
  float a2 = a * a;
  float cos2 = NoH * NoH;
  float tan2 = one_minus_NoH2 / cos2;
  return exp(-tan2 / a2) / (kPi * a2 * cos2 * cos2);
}

float V_SmithGGXCorrelated(float NoV, float NoL, float alpha) {
  float a = max(alpha, kMinAlpha);
  float a2 = a * a;
  float lambda_v = NoL * sqrt(NoV * NoV * (1.0 - a2) + a2);
  float lambda_l = NoV * sqrt(NoL * NoL * (1.0 - a2) + a2);
  return 0.5 / (lambda_v + lambda_l);
}

float V_SmithGGXSeparable(float NoV, float NoL, float alpha) {
  float a = max(alpha, kMinAlpha);
  float a2 = a * a;
  float gv = NoV + sqrt(a2 + (1.0 - a2) * NoV * NoV);
  float gl = NoL + sqrt(a2 + (1.0 - a2) * NoL * NoL);
  return 1.0 / (gv * gl);
}

float G1_SmithBeckmann(float NoX, float alpha) {
  float a = max(alpha, kMinAlpha);
  float sin_x = sqrt(max(1.0 - NoX * NoX, 0.0));
  if (!(sin_x > 0.0)) return 1.0;
  float c = (NoX / sin_x) / a;
  if (c >= 1.6) return 1.0;
  float c2 = c * c;
  return (3.535 * c + 2.181 * c2) / (1.0 + 2.276 * c + 2.577 * c2);
}

float V_SmithBeckmannSeparable(float NoV, float NoL, float alpha) {
  return G1_SmithBeckmann(NoV, alpha) * G1_SmithBeckmann(NoL, alpha) / (4.0 * NoV * NoL);
}

float F_Schlick(float f0, float VoH) { return f0 + (1.0 - f0) * Pow5(1.0 - VoH); }

float F_Dielectric(float cos_i, float eta) {
  float g2 = eta * eta - 1.0 + cos_i * cos_i;
  if (!(g2 > 0.0)) return 1.0;
  float g = sqrt(g2);
  float a = (g - cos_i) / (g + cos_i);
  float b = (cos_i * (g + cos_i) - 1.0) / (cos_i * (g - cos_i) + 1.0);
  return 0.5 * a * a * (1.0 + b * b);
}

float F_Conductor(float cos_i, float eta, float k) {
  float c2 = cos_i * cos_i;
  float s2 = 1.0 - c2;
  float eta2 = eta * eta;
  float k2 = k * k;
  float t0 = eta2 - k2 - s2;
  float a2b2 = sqrt(t0 * t0 + 4.0 * eta2 * k2);
  float a = sqrt(0.5 * (a2b2 + t0) + 1e-12);
  float t1 = a2b2 + c2;
  float t2 = 2.0 * cos_i * a;
  float rs = (t1 - t2) / (t1 + t2);
  float t3 = c2 * a2b2 + s2 * s2;
  float t4 = t2 * s2;
  float rp = rs * (t3 - t4) / (t3 + t4);
  return 0.5 * (rp + rs);
}

float F_CyclesPrincipled(float cspec0, float ior, float LoH) {
  float f0 = F_Dielectric(1.0, ior);
  float fh = (F_Dielectric(LoH, ior) - f0) / (1.0 - f0);
  return cspec0 * (1.0 - fh) + fh;
}

float Fd_Lambert() { return kInvPi; }

float Fd_Burley(float NoV, float NoL, float LoH, float roughness) {
  float f90 = 0.5 + 2.0 * roughness * LoH * LoH;
  float light = 1.0 + (f90 - 1.0) * Pow5(1.0 - NoL);
  float view = 1.0 + (f90 - 1.0) * Pow5(1.0 - NoV);
  return light * view * kInvPi;
}
