// Triangle meshes for scene objects of type "mesh" (docs/scenes.md, "Meshes"): read from OBJ, PLY,
// glTF (and whatever else Assimp reads), placed by a transform, with smooth or flat normals and
// the tangent frame a normal map needs. Every vertex is stored in world space, so the GL
// rasteriser and the CPU ray caster (ray_caster.h) see the same triangles.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "shadefit/render/image.h"
#include "shadefit/render/vec.h"

namespace shadefit {

struct TriangleMesh {
  std::string path;               // The file it was read from ("" when built in memory).
  std::vector<float> positions;   // 3 per vertex, world space.
  std::vector<float> normals;     // 3 per vertex, unit, world space: the shading normals.
  std::vector<float> uvs;         // 2 per vertex; empty when the file has no coordinates.
  std::vector<float> tangents;    // 4 per vertex (unit xyz, handedness +-1); with uvs only.
  std::vector<std::uint32_t> indices;  // 3 per triangle, counter-clockwise seen from the front.

  std::size_t VertexCount() const { return positions.size() / 3; }
  std::size_t TriangleCount() const { return indices.size() / 3; }
  Vec3d Position(std::uint32_t v) const {
    return {positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]};
  }
  Vec3d Normal(std::uint32_t v) const {
    return {normals[3 * v], normals[3 * v + 1], normals[3 * v + 2]};
  }
};

// Object to world: scale, then rotation about X, Y and Z in that order (Blender's default XYZ
// Euler mode, so a Blender object's Location / Rotation / Scale copy over as they are), then the
// translation.
struct MeshTransform {
  Vec3d translate{0, 0, 0};
  Vec3d rotate_deg{0, 0, 0};
  Vec3d scale{1, 1, 1};
  Vec3d Apply(const Vec3d& p) const;
  // Normals transform with the inverse transpose (a non-uniform scale bends them).
  Vec3d ApplyToNormal(const Vec3d& n) const;
};

enum class MeshNormals {
  kAuto,    // The file's normals when it has them, smooth (angle-weighted) otherwise.
  kSmooth,  // Angle-weighted vertex normals, computed (Thurmer and Wuthrich 1998).
  kFlat,    // One normal per face: vertices are split so that no normal is shared.
};

// Reads a mesh file with Assimp (triangulated, identical vertices joined, degenerate faces
// dropped), transformed to world space. Throws shadefit::Error "<path>: mesh: <problem>" for a
// missing or unreadable file, an unknown format, no faces, NaN or infinite vertices or normals,
// indices out of range, or more than kMaxMeshTriangles triangles. Cached by path, file contents
// and settings: every scene of a study that names the same mesh shares one copy.
std::shared_ptr<const TriangleMesh> LoadMesh(const std::string& path,
                                             const MeshTransform& transform,
                                             MeshNormals normals);

// Checks a mesh built in memory as LoadMesh checks a file's (name = what to call it); fills the
// tangents when it has uvs and none. Throws the same errors.
void ValidateMesh(const std::string& name, TriangleMesh* mesh);

// Vertex normals weighted by the angle each face makes at the vertex (Thurmer and Wuthrich 1998,
// "Computing vertex normals from polygonal facets"), replacing mesh->normals.
void ComputeSmoothNormals(TriangleMesh* mesh);

// Per-vertex tangents for tangent-space normal maps from the uv layout (Lengyel 2001,
// "Computing Tangent Space Basis Vectors for an Arbitrary Mesh"), orthogonalised against the
// normal; handedness in w. Needs uvs.
void ComputeTangents(TriangleMesh* mesh);

// The largest mesh a scene may name (the GL buffers and the ray caster's memory stay bounded).
constexpr std::size_t kMaxMeshTriangles = 20'000'000;

// A tangent-space normal map (docs/scenes.md, "Normal maps"): RGB in [0, 1] maps to a unit
// vector 2 * rgb - 1 in the frame (tangent, bitangent, normal), green along +v (the OpenGL /
// Blender convention; a DirectX-style map needs flip_green). Sampled bilinearly, repeating.
struct NormalMap {
  std::string path;
  Image image;  // 3 channels, the file's stored values in [0, 1] (never sRGB-decoded).
  bool flip_green = false;
  Vec3d Sample(double u, double v) const;  // The unit tangent-space normal at (u, v).
};
std::shared_ptr<const NormalMap> LoadNormalMap(const std::string& path, bool flip_green);

}  // namespace shadefit
