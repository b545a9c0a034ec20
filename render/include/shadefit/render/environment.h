// Equirectangular environment maps: radiance lookup with Cycles' orientation and the tabulated
// luminance distribution used to importance-sample them (render/shaders/environment.glsl).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "shadefit/render/image.h"
#include "shadefit/render/vec.h"

namespace shadefit {

class EnvironmentMap {
 public:
  // Reads an EXR/HDR map (RGB, linear). Throws shadefit::Error naming the file.
  EnvironmentMap(const std::string& path, double strength, double rotation_z_deg);
  // A map made from pixels (tests).
  EnvironmentMap(Image radiance, double strength, double rotation_z_deg);

  // Radiance arriving from world direction `dir` (unit), bilinear like the GL lookup.
  Vec3d Radiance(const Vec3d& dir) const;
  // Density of Sample() over solid angle.
  double Pdf(const Vec3d& dir) const;
  // Direction (world) for a point of the unit square, distributed as Pdf().
  Vec3d Sample(double u1, double u2) const;
  // The renderer's fixed sample set: n directions in map space from a Hammersley set.
  std::vector<float> SampleSetMapSpace(int n) const;

  const Image& radiance() const { return radiance_; }
  const Image& pdf_image() const { return pdf_; }   // density over (u, v), row 0 = top
  double strength() const { return strength_; }
  // Rotation world -> map (about +Z), row-major 3x3.
  const double* world_to_map() const { return world_to_map_; }
  Vec3d WorldToMap(const Vec3d& d) const;
  Vec3d MapToWorld(const Vec3d& d) const;

 private:
  void BuildDistribution();
  Vec3d SampleMapSpace(double u1, double u2, double* u, double* v) const;

  Image radiance_;   // RGB, row 0 = top (v = 1)
  Image pdf_;        // 1 channel, density over the unit (u, v) square
  std::vector<double> marginal_cdf_;     // over rows (size h + 1)
  std::vector<double> conditional_cdf_;  // per row (h x (w + 1))
  double strength_ = 1.0;
  double world_to_map_[9];
};

// The 32 bits of `bits` in reverse order (environment.glsl's RadicalInverse reverses them too).
std::uint32_t ReverseBits32(std::uint32_t bits);
// Van der Corput radical inverse in base 2 (bit reversal): the second coordinate of the
// Hammersley point sets of the environment samplers.
double RadicalInverseBase2(std::uint32_t bits);

// Directions in map space <-> equirectangular (u, v), v = 0 at the bottom (Cycles).
void DirectionToEquirect(const Vec3d& d, double* u, double* v);
Vec3d EquirectToDirection(double u, double v);

// The distant light that the CPU integrators (the twin's quadrature, gbuffer.h; the measured
// renderer, reference_images/) sample: an equirectangular map, or a uniform radiance when `map`
// is null (uniform density over the sphere).
struct DistantLight {
  std::shared_ptr<const EnvironmentMap> map;
  Vec3d uniform{0, 0, 0};

  Vec3d Radiance(const Vec3d& d) const { return map ? map->Radiance(d) : uniform; }
  double Pdf(const Vec3d& d) const;
  Vec3d Sample(double u1, double u2) const;
};

// Loads once per (path, strength, rotation) and shares the result between renderers.
std::shared_ptr<const EnvironmentMap> LoadEnvironmentCached(const std::string& path,
                                                            double strength,
                                                            double rotation_z_deg);

}  // namespace shadefit
