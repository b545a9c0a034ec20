// A three-component vector templated on its scalar. Deliberately not glm: glm only accepts
// arithmetic types, and the BRDF code must also run on ceres::Jet (STYLE.md).
#pragma once

#include <cmath>

namespace shadefit {

template <typename S>
struct Vec3 {
  S x{}, y{}, z{};
  Vec3() = default;
  Vec3(S x_, S y_, S z_) : x(x_), y(y_), z(z_) {}
  S& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  const S& operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  Vec3 operator-() const { return {-x, -y, -z}; }
  Vec3 operator*(const S& s) const { return {x * s, y * s, z * s}; }
  Vec3 operator/(const S& s) const { return {x / s, y / s, z / s}; }
  Vec3& operator+=(const Vec3& o) { x += o.x; y += o.y; z += o.z; return *this; }
};

using Vec3d = Vec3<double>;

template <typename S>
S Dot(const Vec3<S>& a, const Vec3<S>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

template <typename S>
Vec3<S> Cross(const Vec3<S>& a, const Vec3<S>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

template <typename S>
S Length(const Vec3<S>& a) {
  using std::sqrt;
  return sqrt(Dot(a, a));
}

// Callers guarantee a non-zero vector (geometry code only; never applied to parameters).
template <typename S>
Vec3<S> Normalize(const Vec3<S>& a) {
  return a / Length(a);
}

}  // namespace shadefit
