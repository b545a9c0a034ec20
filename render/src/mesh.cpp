#include "shadefit/render/mesh.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <fmt/format.h>

#include <assimp/Importer.hpp>
#include <cmath>
#include <map>
#include <mutex>

#include "shadefit/base/error.h"
#include "shadefit/base/files.h"

namespace shadefit {
namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

// R = Rz * Ry * Rx (Blender's XYZ Euler: X is applied first), row-major.
void RotationMatrix(const Vec3d& deg, double m[9]) {
  const double cx = std::cos(deg.x * kDegToRad), sx = std::sin(deg.x * kDegToRad);
  const double cy = std::cos(deg.y * kDegToRad), sy = std::sin(deg.y * kDegToRad);
  const double cz = std::cos(deg.z * kDegToRad), sz = std::sin(deg.z * kDegToRad);
  const double r[9] = {cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx,
                       sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx,
                       -sy,     cy * sx,                cy * cx};
  for (int i = 0; i < 9; ++i) m[i] = r[i];
}

Vec3d Rotate(const double m[9], const Vec3d& v) {
  return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[3] * v.x + m[4] * v.y + m[5] * v.z,
          m[6] * v.x + m[7] * v.y + m[8] * v.z};
}

bool Finite(const Vec3d& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

[[noreturn]] void Fail(const std::string& name, const std::string& problem) {
  throw Error(name, "mesh", problem);
}

// Splits every vertex so that each triangle has its own three: flat normals need that.
void Unshare(TriangleMesh* mesh) {
  TriangleMesh out;
  out.path = mesh->path;
  const bool uv = !mesh->uvs.empty();
  for (std::uint32_t idx : mesh->indices) {
    for (int k = 0; k < 3; ++k) out.positions.push_back(mesh->positions[3 * idx + k]);
    if (uv) {
      for (int k = 0; k < 2; ++k) out.uvs.push_back(mesh->uvs[2 * idx + k]);
    }
    out.indices.push_back(static_cast<std::uint32_t>(out.indices.size()));
  }
  out.normals.assign(out.positions.size(), 0.0f);
  for (std::size_t t = 0; t < out.TriangleCount(); ++t) {
    const Vec3d a = out.Position(3 * t), b = out.Position(3 * t + 1), c = out.Position(3 * t + 2);
    const Vec3d n = Cross(b - a, c - a);
    const double len = Length(n);
    const Vec3d u = len > 0 ? n / len : Vec3d{0, 0, 1};
    for (int k = 0; k < 3; ++k) {
      for (int j = 0; j < 3; ++j) out.normals[9 * t + 3 * k + j] = static_cast<float>(u[j]);
    }
  }
  *mesh = std::move(out);
}

TriangleMesh ReadWithAssimp(const std::string& path) {
  Assimp::Importer importer;
  // Points and lines are removed, polygons triangulated, the node hierarchy's transforms baked
  // into the vertices (a glTF's nodes place its meshes), identical vertices joined.
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  importer.SetPropertyBool(AI_CONFIG_PP_FD_REMOVE, true);
  const aiScene* scene = importer.ReadFile(
      path, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_SortByPType |
                aiProcess_FindDegenerates | aiProcess_PreTransformVertices |
                aiProcess_ValidateDataStructure);
  if (!scene) {
    std::string why = importer.GetErrorString();
    why = why.substr(0, why.find('\n'));
    Fail(path, "cannot read it as a mesh: " + (why.empty() ? std::string("unknown format") : why));
  }
  TriangleMesh mesh;
  mesh.path = path;
  bool all_normals = scene->mNumMeshes > 0, all_uvs = scene->mNumMeshes > 0;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    all_normals = all_normals && scene->mMeshes[m]->HasNormals();
    all_uvs = all_uvs && scene->mMeshes[m]->HasTextureCoords(0);
  }
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* am = scene->mMeshes[m];
    if (!(am->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
    const auto base = static_cast<std::uint32_t>(mesh.VertexCount());
    for (unsigned v = 0; v < am->mNumVertices; ++v) {
      for (int k = 0; k < 3; ++k) mesh.positions.push_back(am->mVertices[v][k]);
      if (all_normals) {
        for (int k = 0; k < 3; ++k) mesh.normals.push_back(am->mNormals[v][k]);
      }
      if (all_uvs) {
        mesh.uvs.push_back(am->mTextureCoords[0][v].x);
        mesh.uvs.push_back(am->mTextureCoords[0][v].y);
      }
    }
    for (unsigned f = 0; f < am->mNumFaces; ++f) {
      const aiFace& face = am->mFaces[f];
      if (face.mNumIndices != 3) continue;
      for (int k = 0; k < 3; ++k) {
        if (face.mIndices[k] >= am->mNumVertices) {
          Fail(path, fmt::format("face {} of mesh {} names vertex {}, out of range (it has {})", f,
                                 m, face.mIndices[k], am->mNumVertices));
        }
        mesh.indices.push_back(base + face.mIndices[k]);
      }
    }
  }
  return mesh;
}

std::string TransformKey(const MeshTransform& t) {
  return fmt::format("{:.17g},{:.17g},{:.17g};{:.17g},{:.17g},{:.17g};{:.17g},{:.17g},{:.17g}",
                     t.translate.x, t.translate.y, t.translate.z, t.rotate_deg.x, t.rotate_deg.y,
                     t.rotate_deg.z, t.scale.x, t.scale.y, t.scale.z);
}

}  // namespace

Vec3d MeshTransform::Apply(const Vec3d& p) const {
  double r[9];
  RotationMatrix(rotate_deg, r);
  return Rotate(r, Vec3d{p.x * scale.x, p.y * scale.y, p.z * scale.z}) + translate;
}

Vec3d MeshTransform::ApplyToNormal(const Vec3d& n) const {
  double r[9];
  RotationMatrix(rotate_deg, r);
  const Vec3d m = Rotate(r, Vec3d{n.x / scale.x, n.y / scale.y, n.z / scale.z});
  const double len = Length(m);
  return len > 0 ? m / len : m;
}

void ComputeSmoothNormals(TriangleMesh* mesh) {
  std::vector<double> acc(mesh->positions.size(), 0.0);
  for (std::size_t t = 0; t < mesh->TriangleCount(); ++t) {
    const std::uint32_t* i = &mesh->indices[3 * t];
    const Vec3d p[3] = {mesh->Position(i[0]), mesh->Position(i[1]), mesh->Position(i[2])};
    const Vec3d n = Cross(p[1] - p[0], p[2] - p[0]);
    const double len = Length(n);
    if (!(len > 0)) continue;
    for (int k = 0; k < 3; ++k) {
      const Vec3d e1 = p[(k + 1) % 3] - p[k], e2 = p[(k + 2) % 3] - p[k];
      const double l1 = Length(e1), l2 = Length(e2);
      if (!(l1 > 0 && l2 > 0)) continue;
      const double angle = std::acos(std::clamp(Dot(e1, e2) / (l1 * l2), -1.0, 1.0));
      for (int j = 0; j < 3; ++j) acc[3 * i[k] + j] += angle * n[j] / len;
    }
  }
  mesh->normals.assign(mesh->positions.size(), 0.0f);
  for (std::size_t v = 0; v < mesh->VertexCount(); ++v) {
    const Vec3d n{acc[3 * v], acc[3 * v + 1], acc[3 * v + 2]};
    const double len = Length(n);
    // A vertex of degenerate faces only: any unit vector (it shades nothing visible).
    const Vec3d u = len > 0 ? n / len : Vec3d{0, 0, 1};
    for (int j = 0; j < 3; ++j) mesh->normals[3 * v + j] = static_cast<float>(u[j]);
  }
}

void ComputeTangents(TriangleMesh* mesh) {
  const std::size_t nv = mesh->VertexCount();
  std::vector<double> tan(3 * nv, 0.0), bit(3 * nv, 0.0);
  for (std::size_t t = 0; t < mesh->TriangleCount(); ++t) {
    const std::uint32_t* i = &mesh->indices[3 * t];
    const Vec3d e1 = mesh->Position(i[1]) - mesh->Position(i[0]);
    const Vec3d e2 = mesh->Position(i[2]) - mesh->Position(i[0]);
    const double du1 = mesh->uvs[2 * i[1]] - mesh->uvs[2 * i[0]];
    const double dv1 = mesh->uvs[2 * i[1] + 1] - mesh->uvs[2 * i[0] + 1];
    const double du2 = mesh->uvs[2 * i[2]] - mesh->uvs[2 * i[0]];
    const double dv2 = mesh->uvs[2 * i[2] + 1] - mesh->uvs[2 * i[0] + 1];
    const double det = du1 * dv2 - du2 * dv1;
    if (!(std::abs(det) > 1e-20)) continue;
    const Vec3d sdir = (e1 * dv2 - e2 * dv1) / det;
    const Vec3d tdir = (e2 * du1 - e1 * du2) / det;
    for (int k = 0; k < 3; ++k) {
      for (int j = 0; j < 3; ++j) {
        tan[3 * i[k] + j] += sdir[j];
        bit[3 * i[k] + j] += tdir[j];
      }
    }
  }
  mesh->tangents.assign(4 * nv, 0.0f);
  for (std::size_t v = 0; v < nv; ++v) {
    const Vec3d n = mesh->Normal(static_cast<std::uint32_t>(v));
    const Vec3d t{tan[3 * v], tan[3 * v + 1], tan[3 * v + 2]};
    Vec3d o = t - n * Dot(n, t);  // Gram-Schmidt against the normal.
    double len = Length(o);
    if (!(len > 1e-12)) {  // No uv gradient here: any tangent of the normal's plane.
      const Vec3d ref = std::abs(n.x) > 0.9 ? Vec3d{0, 1, 0} : Vec3d{1, 0, 0};
      o = Cross(n, ref);
      len = Length(o);
    }
    o = o / len;
    const Vec3d b{bit[3 * v], bit[3 * v + 1], bit[3 * v + 2]};
    const float hand = Dot(Cross(n, o), b) < 0 ? -1.0f : 1.0f;
    for (int j = 0; j < 3; ++j) mesh->tangents[4 * v + j] = static_cast<float>(o[j]);
    mesh->tangents[4 * v + 3] = hand;
  }
}

void ValidateMesh(const std::string& name, TriangleMesh* mesh) {
  if (mesh->positions.size() % 3 != 0 || mesh->indices.size() % 3 != 0) {
    Fail(name, "positions and indices must come in threes");
  }
  if (mesh->TriangleCount() == 0) Fail(name, "no faces (a mesh needs at least one triangle)");
  if (mesh->TriangleCount() > kMaxMeshTriangles) {
    Fail(name, fmt::format("{} triangles, more than the {} a scene may hold",
                           mesh->TriangleCount(), kMaxMeshTriangles));
  }
  for (std::size_t v = 0; v < mesh->VertexCount(); ++v) {
    const Vec3d p = mesh->Position(static_cast<std::uint32_t>(v));
    if (!Finite(p)) {
      Fail(name, fmt::format("vertex {} is ({}, {}, {}): not finite", v, p.x, p.y, p.z));
    }
    // The GL renderer works in float32 (scene.cpp's kMaxMagnitude).
    if (std::abs(p.x) > 1e9 || std::abs(p.y) > 1e9 || std::abs(p.z) > 1e9) {
      Fail(name, fmt::format("vertex {} lies beyond +-1e9", v));
    }
  }
  for (std::size_t k = 0; k < mesh->indices.size(); ++k) {
    if (mesh->indices[k] >= mesh->VertexCount()) {
      Fail(name, fmt::format("index {} of triangle {} is {}, out of range (the mesh has {} "
                             "vertices)", k % 3, k / 3, mesh->indices[k], mesh->VertexCount()));
    }
  }
  if (!mesh->normals.empty()) {
    if (mesh->normals.size() != mesh->positions.size()) Fail(name, "one normal per vertex needed");
    for (std::size_t v = 0; v < mesh->VertexCount(); ++v) {
      const Vec3d n = mesh->Normal(static_cast<std::uint32_t>(v));
      if (!Finite(n)) Fail(name, fmt::format("normal {} is not finite", v));
    }
  }
  if (!mesh->uvs.empty() && mesh->uvs.size() != 2 * mesh->VertexCount()) {
    Fail(name, "one texture coordinate per vertex needed");
  }
  for (float u : mesh->uvs) {
    if (!std::isfinite(u)) Fail(name, "a texture coordinate is not finite");
  }
  if (mesh->normals.empty()) ComputeSmoothNormals(mesh);
  if (!mesh->uvs.empty() && mesh->tangents.empty()) ComputeTangents(mesh);
}

std::shared_ptr<const TriangleMesh> LoadMesh(const std::string& path,
                                             const MeshTransform& transform,
                                             MeshNormals normals) {
  const PathKind kind = KindOfPath(path, "mesh");
  if (kind == PathKind::kMissing) Fail(path, "file not found");
  if (kind != PathKind::kFile) Fail(path, "not a regular file");
  if (!(std::abs(transform.scale.x) > 0 && std::abs(transform.scale.y) > 0 &&
        std::abs(transform.scale.z) > 0)) {
    Fail(path, "scale must not be 0 along any axis");
  }
  const std::string key = fmt::format("{}|{}|{}|{}", path, Sha256File(path),
                                      TransformKey(transform), static_cast<int>(normals));
  static std::mutex mutex;
  static std::map<std::string, std::shared_ptr<const TriangleMesh>> cache;
  {
    std::lock_guard<std::mutex> lock(mutex);
    auto it = cache.find(key);
    if (it != cache.end()) return it->second;
  }
  TriangleMesh mesh = ReadWithAssimp(path);
  // Checked in the file's own coordinates first, so that a NaN is reported as the file has it.
  const bool had_normals = !mesh.normals.empty();
  std::vector<float> file_normals = mesh.normals;
  mesh.normals.clear();
  ValidateMesh(path, &mesh);  // Computes smooth normals and, with uvs, tangents.
  if (had_normals) {
    for (float n : file_normals) {
      if (!std::isfinite(n)) Fail(path, "a normal in the file is not finite");
    }
  }
  const bool determinant_negative = transform.scale.x * transform.scale.y * transform.scale.z < 0;
  for (std::size_t v = 0; v < mesh.VertexCount(); ++v) {
    const Vec3d p = transform.Apply(mesh.Position(static_cast<std::uint32_t>(v)));
    for (int j = 0; j < 3; ++j) mesh.positions[3 * v + j] = static_cast<float>(p[j]);
  }
  if (determinant_negative) {  // A mirror turns the winding: keep counter-clockwise in front.
    for (std::size_t t = 0; t < mesh.TriangleCount(); ++t) {
      std::swap(mesh.indices[3 * t + 1], mesh.indices[3 * t + 2]);
    }
  }
  if (normals == MeshNormals::kFlat) {
    Unshare(&mesh);
  } else if (normals == MeshNormals::kAuto && had_normals) {
    for (std::size_t v = 0; v < mesh.VertexCount(); ++v) {
      Vec3d n{file_normals[3 * v], file_normals[3 * v + 1], file_normals[3 * v + 2]};
      n = Length(n) > 0 ? transform.ApplyToNormal(n) : Vec3d{0, 0, 1};
      for (int j = 0; j < 3; ++j) mesh.normals[3 * v + j] = static_cast<float>(n[j]);
    }
  } else {
    ComputeSmoothNormals(&mesh);  // In world space: a non-uniform scale changes the weights.
  }
  mesh.tangents.clear();
  if (!mesh.uvs.empty()) ComputeTangents(&mesh);
  auto shared = std::make_shared<const TriangleMesh>(std::move(mesh));
  std::lock_guard<std::mutex> lock(mutex);
  return cache.emplace(key, shared).first->second;
}

Vec3d NormalMap::Sample(double u, double v) const {
  // Texture space: v = 0 is the bottom row of the image (OpenGL, Blender).
  const double fx = (u - std::floor(u)) * image.width - 0.5;
  const double fy = (1.0 - (v - std::floor(v))) * image.height - 0.5;
  const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
  const double ax = fx - x0, ay = fy - y0;
  auto wrap = [](int i, int n) { return ((i % n) + n) % n; };
  Vec3d rgb{0, 0, 0};
  for (int dy = 0; dy < 2; ++dy) {
    for (int dx = 0; dx < 2; ++dx) {
      const double w = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay);
      const int x = wrap(x0 + dx, image.width), y = wrap(y0 + dy, image.height);
      for (int c = 0; c < 3; ++c) rgb[c] += w * image.at(x, y, c);
    }
  }
  Vec3d n = rgb * 2.0 - Vec3d{1, 1, 1};
  if (flip_green) n.y = -n.y;
  const double len = Length(n);
  return len > 1e-12 ? n / len : Vec3d{0, 0, 1};
}

std::shared_ptr<const NormalMap> LoadNormalMap(const std::string& path, bool flip_green) {
  static std::mutex mutex;
  static std::map<std::string, std::shared_ptr<const NormalMap>> cache;
  const std::string key = fmt::format("{}|{}|{}", path, Sha256File(path), flip_green);
  {
    std::lock_guard<std::mutex> lock(mutex);
    auto it = cache.find(key);
    if (it != cache.end()) return it->second;
  }
  NormalMap map;
  map.path = path;
  map.flip_green = flip_green;
  Image img = ReadImage(path);
  if (img.channels < 3) throw Error(path, "normal_map", "expected an RGB image");
  map.image = img.channels == 3 ? std::move(img) : img.Channels(0, 3);
  for (float v : map.image.data) {
    if (!std::isfinite(v)) throw Error(path, "normal_map", "a pixel is not finite");
  }
  auto shared = std::make_shared<const NormalMap>(std::move(map));
  std::lock_guard<std::mutex> lock(mutex);
  return cache.emplace(key, shared).first->second;
}

}  // namespace shadefit
