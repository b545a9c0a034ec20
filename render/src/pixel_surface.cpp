#include "shadefit/render/pixel_surface.h"

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <fmt/format.h>
#include <matio.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <regex>
#include <sstream>

#include "shadefit/base/error.h"
#include "shadefit/base/files.h"
#include "shadefit/render/brdf.h"
#include "shadefit/render/scene.h"

namespace shadefit {
namespace {

namespace fs = std::filesystem;

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

struct RawNormals {
  int width = 0, height = 0;
  std::vector<double> xyz;  // 3 per pixel, row-major, as stored.
};

// NumPy's .npy format (version 1-3): magic, header dict, then the array.
RawNormals ReadNpy(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "normals", "cannot open");
  char magic[6];
  in.read(magic, 6);
  if (!in || std::memcmp(magic, "\x93NUMPY", 6) != 0) throw Error(path, "normals", "not a .npy file");
  unsigned char version[2];
  in.read(reinterpret_cast<char*>(version), 2);
  std::uint32_t header_len = 0;
  if (version[0] == 1) {
    unsigned char b[2];
    in.read(reinterpret_cast<char*>(b), 2);
    header_len = b[0] | (b[1] << 8);
  } else {
    unsigned char b[4];
    in.read(reinterpret_cast<char*>(b), 4);
    header_len = b[0] | (b[1] << 8) | (b[2] << 16) | (static_cast<std::uint32_t>(b[3]) << 24);
  }
  if (!in || header_len > 1 << 20) throw Error(path, "normals", "truncated .npy header");
  std::string header(header_len, '\0');
  in.read(header.data(), header_len);
  if (!in) throw Error(path, "normals", "truncated .npy header");
  std::smatch m;
  if (!std::regex_search(header, m, std::regex(R"('descr':\s*'([<>|=])([fi])(\d+)')"))) {
    throw Error(path, "normals", "the .npy header names no numeric dtype");
  }
  const char order = m[1].str()[0];
  const char kind = m[2].str()[0];
  const int bytes = std::stoi(m[3].str());
  if (order == '>' || kind != 'f' || (bytes != 4 && bytes != 8)) {
    throw Error(path, "normals", "expected little-endian float32 or float64 normals");
  }
  if (std::regex_search(header, std::regex(R"('fortran_order':\s*True)"))) {
    throw Error(path, "normals", "Fortran-ordered arrays are not read (save with C order)");
  }
  if (!std::regex_search(header, m, std::regex(R"('shape':\s*\((\d+),\s*(\d+),\s*(\d+)\s*,?\))"))) {
    throw Error(path, "normals", "expected an array of shape (height, width, 3)");
  }
  RawNormals raw;
  raw.height = std::stoi(m[1].str());
  raw.width = std::stoi(m[2].str());
  if (std::stoi(m[3].str()) != 3) throw Error(path, "normals", "the last axis must have 3 entries");
  if (raw.width < 1 || raw.height < 1 || raw.width > 16384 || raw.height > 16384) {
    throw Error(path, "normals", "width and height must be 1..16384");
  }
  const std::size_t n = static_cast<std::size_t>(raw.width) * raw.height * 3;
  raw.xyz.resize(n);
  if (bytes == 8) {
    in.read(reinterpret_cast<char*>(raw.xyz.data()), static_cast<std::streamsize>(n * 8));
  } else {
    std::vector<float> f(n);
    in.read(reinterpret_cast<char*>(f.data()), static_cast<std::streamsize>(n * 4));
    std::copy(f.begin(), f.end(), raw.xyz.begin());
  }
  if (!in) throw Error(path, "normals", "the .npy file is shorter than its shape");
  return raw;
}

// MATLAB .mat (v4, v5, compressed v5; libmatio): the named variable or the only H x W x 3 one.
RawNormals ReadMat(const std::string& path, const std::string& variable) {
  mat_t* mat = Mat_Open(path.c_str(), MAT_ACC_RDONLY);
  if (!mat) throw Error(path, "normals", "cannot open as a MATLAB .mat file");
  matvar_t* var = nullptr;
  std::vector<std::string> seen;
  if (!variable.empty()) {
    var = Mat_VarRead(mat, variable.c_str());
    if (!var) {
      Mat_Close(mat);
      throw Error(path, "variable", fmt::format("no variable '{}' in the file", variable));
    }
  } else {
    while (matvar_t* info = Mat_VarReadNextInfo(mat)) {
      const bool fits = info->rank == 3 && info->dims[2] == 3 && info->isComplex == 0 &&
                        info->class_type != MAT_C_CELL && info->class_type != MAT_C_STRUCT &&
                        info->class_type != MAT_C_CHAR;
      if (fits) seen.push_back(info->name ? info->name : "");
      Mat_VarFree(info);
    }
    if (seen.size() != 1) {
      Mat_Close(mat);
      throw Error(path, "variable",
                  seen.empty() ? "no H x W x 3 numeric array in the file"
                               : fmt::format("{} H x W x 3 arrays ({}...): name one with variable",
                                             seen.size(), seen[0]));
    }
    var = Mat_VarRead(mat, seen[0].c_str());
  }
  Mat_Close(mat);  // Mat_VarRead has read the data.
  if (!var) throw Error(path, "normals", "cannot read the variable");
  RawNormals raw;
  const bool ok = var->rank == 3 && var->dims[2] == 3 && var->data && var->isComplex == 0;
  if (!ok) {
    Mat_VarFree(var);
    throw Error(path, "normals", "expected a real H x W x 3 array");
  }
  raw.height = static_cast<int>(var->dims[0]);
  raw.width = static_cast<int>(var->dims[1]);
  const std::size_t n = static_cast<std::size_t>(raw.width) * raw.height;
  raw.xyz.resize(3 * n);
  auto value = [&](std::size_t k) -> double {
    switch (var->data_type) {
      case MAT_T_DOUBLE: return static_cast<const double*>(var->data)[k];
      case MAT_T_SINGLE: return static_cast<const float*>(var->data)[k];
      default: return std::nan("");
    }
  };
  if (var->data_type != MAT_T_DOUBLE && var->data_type != MAT_T_SINGLE) {
    Mat_VarFree(var);
    throw Error(path, "normals", "expected double or single normals");
  }
  // MATLAB stores column-major: element (row, col, c) at row + H * (col + W * c).
  for (int y = 0; y < raw.height; ++y) {
    for (int x = 0; x < raw.width; ++x) {
      for (int c = 0; c < 3; ++c) {
        raw.xyz[(static_cast<std::size_t>(y) * raw.width + x) * 3 + c] =
            value(static_cast<std::size_t>(y) + raw.height * (x + static_cast<std::size_t>(raw.width) * c));
      }
    }
  }
  Mat_VarFree(var);
  return raw;
}

// Whitespace- or comma-separated numbers, 3 per pixel in row-major order.
RawNormals ReadText(const std::string& path, int width, int height) {
  std::ifstream in(path);
  if (!in) throw Error(path, "normals", "cannot open");
  RawNormals raw;
  raw.width = width;
  raw.height = height;
  const std::size_t n = static_cast<std::size_t>(width) * height * 3;
  raw.xyz.reserve(n);
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream ss(line);
    std::string tok;
    while (ss >> tok) {
      char* end = nullptr;
      const double v = std::strtod(tok.c_str(), &end);
      if (end == tok.c_str() || *end != '\0') {
        throw Error(fmt::format("{}:{}", path, line_no), "normals",
                    fmt::format("'{}' is not a number", tok));
      }
      if (raw.xyz.size() == n) {
        throw Error(path, "normals", fmt::format("more than the {} x {} x 3 numbers the mask's size "
                                                 "needs", height, width));
      }
      raw.xyz.push_back(v);
    }
  }
  if (raw.xyz.size() != n) {
    throw Error(path, "normals", fmt::format("{} numbers, expected {} ({} x {} pixels x 3)",
                                             raw.xyz.size(), n, height, width));
  }
  return raw;
}

RawNormals ReadImageNormals(const std::string& path, bool* eight_bit) {
  const Image img = ReadImage(path);
  if (img.channels < 3) throw Error(path, "normals", "expected an RGB image of normals");
  RawNormals raw;
  raw.width = img.width;
  raw.height = img.height;
  raw.xyz.resize(img.PixelCount() * 3);
  const std::string ext = Lower(fs::path(path).extension().string());
  const bool stored_unsigned = ext != ".exr" && ext != ".hdr" && ext != ".pfm";
  ImageFileInfo info;
  std::string error;
  *eight_bit = stored_unsigned && ReadImageInfo(path, &info, &error) &&
               info.format.find("uint8") != std::string::npos;
  for (std::size_t i = 0; i < img.PixelCount(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const double v = img.data[i * img.channels + c];
      raw.xyz[3 * i + c] = stored_unsigned ? 2.0 * v - 1.0 : v;  // [0, 1] encodes [-1, 1].
    }
  }
  return raw;
}

}  // namespace

NormalImage ReadNormalImage(const std::string& path, const std::string& mask_path,
                            const std::string& variable, bool y_down, bool check_facing) {
  const PathKind kind = KindOfPath(path, "normals");
  if (kind == PathKind::kMissing) throw Error(path, "normals", "file not found");
  if (kind != PathKind::kFile) throw Error(path, "normals", "not a regular file");
  Image mask_image;
  if (!mask_path.empty()) {
    if (!PathExists(mask_path, "mask")) throw Error(mask_path, "mask", "file not found");
    mask_image = ReadImage(mask_path);
  }
  const std::string ext = Lower(fs::path(path).extension().string());
  RawNormals raw;
  bool eight_bit = false;
  if (ext == ".npy") {
    raw = ReadNpy(path);
  } else if (ext == ".mat") {
    raw = ReadMat(path, variable);
  } else if (ext == ".txt" || ext == ".csv") {
    if (mask_image.empty()) {
      throw Error(path, "mask", "text normals need a mask image: it gives the width and height");
    }
    raw = ReadText(path, mask_image.width, mask_image.height);
  } else {
    raw = ReadImageNormals(path, &eight_bit);
  }
  if (!variable.empty() && ext != ".mat") {
    throw Error(path, "variable", "only a .mat file has variables");
  }
  NormalImage out;
  out.width = raw.width;
  out.height = raw.height;
  const std::size_t n = static_cast<std::size_t>(raw.width) * raw.height;
  if (!mask_image.empty() && (mask_image.width != raw.width || mask_image.height != raw.height)) {
    throw Error(mask_path, "mask", fmt::format("is {}x{} but the normals are {}x{}", mask_image.width,
                                               mask_image.height, raw.width, raw.height));
  }
  out.mask.assign(n, 0);
  out.normal.assign(3 * n, 0.0f);
  const double tolerance = eight_bit ? 0.05 : 0.02;
  std::size_t masked = 0, facing = 0;
  for (std::size_t i = 0; i < n; ++i) {
    double v[3] = {raw.xyz[3 * i], raw.xyz[3 * i + 1], raw.xyz[3 * i + 2]};
    const double len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    const int x = static_cast<int>(i % raw.width), y = static_cast<int>(i / raw.width);
    if (!std::isfinite(len)) {
      // A data set may mark the background with NaN; inside the mask it is an error.
      if (!mask_image.empty() && mask_image.data[i * mask_image.channels] > 0.5f) {
        throw Error(path, "normals", fmt::format("pixel ({}, {}) is not finite", x, y));
      }
      continue;
    }
    const bool in_mask = mask_image.empty() ? len > 0.5 : mask_image.data[i * mask_image.channels] > 0.5f;
    if (!in_mask) continue;
    if (std::abs(len - 1.0) > tolerance) {
      throw Error(path, "normals",
                  fmt::format("pixel ({}, {}) has length {:.4g}, not 1 (within {}): are these "
                              "normals, encoded as the file type says?", x, y, len, tolerance));
    }
    if (y_down) v[1] = -v[1];
    out.mask[i] = 1;
    ++masked;
    facing += v[2] > 0;
    for (int c = 0; c < 3; ++c) out.normal[3 * i + c] = static_cast<float>(v[c] / len);
  }
  if (masked == 0) throw Error(mask_path.empty() ? path : mask_path, "mask", "no pixel is masked in");
  if (check_facing && facing < 0.9 * masked) {
    throw Error(path, "normals",
                fmt::format("only {:.0f}% of the masked normals face the camera (z > 0): the "
                            "convention is x right, y up, z toward the camera; is z flipped?",
                            100.0 * facing / masked));
  }
  return out;
}

void WriteNormalsNpy(const std::string& path, const NormalImage& n) {
  std::string header = fmt::format("{{'descr': '<f4', 'fortran_order': False, 'shape': ({}, {}, 3), }}",
                                   n.height, n.width);
  while ((10 + header.size() + 1) % 64 != 0) header += ' ';
  header += '\n';
  const std::string tmp = path + ".partial";
  {
    std::ofstream out(tmp, std::ios::binary);
    out.write("\x93NUMPY\x01\x00", 8);
    const unsigned char len[2] = {static_cast<unsigned char>(header.size() & 0xFF),
                                  static_cast<unsigned char>(header.size() >> 8)};
    out.write(reinterpret_cast<const char*>(len), 2);
    out << header;
    for (std::size_t i = 0; i < n.normal.size(); ++i) {
      const float v = n.mask[i / 3] ? n.normal[i] : 0.0f;
      out.write(reinterpret_cast<const char*>(&v), 4);
    }
    if (!out) throw Error(path, "normals", "cannot write");
  }
  fs::rename(tmp, path);
}

std::vector<double> IntegrateNormals(const NormalImage& img, double pixel_size, double base_depth) {
  const int w = img.width, h = img.height;
  const std::size_t n = static_cast<std::size_t>(w) * h;
  std::vector<int> unknown(n, -1);
  int count = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (img.mask[i]) unknown[i] = count++;
  }
  // Height toward the camera: along +x (a column to the right) dh = -nx/nz s; one row down
  // (y up in the normals' frame) dh = +ny/nz s.
  auto slope = [&](std::size_t i, int axis) {
    const double nz = std::max(static_cast<double>(img.normal[3 * i + 2]), 1.0 / kMaxIntegratedSlope);
    return std::clamp(-img.normal[3 * i + axis] / nz, -kMaxIntegratedSlope, kMaxIntegratedSlope);
  };
  std::vector<Eigen::Triplet<double>> triplets;
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(count);
  std::vector<double> diagonal(count, 0.0);
  auto edge = [&](std::size_t a, std::size_t b, double g) {  // h_b - h_a = g
    const int ia = unknown[a], ib = unknown[b];
    diagonal[ia] += 1;
    diagonal[ib] += 1;
    triplets.emplace_back(ia, ib, -1.0);
    triplets.emplace_back(ib, ia, -1.0);
    rhs[ib] += g;
    rhs[ia] -= g;
  };
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * w + x;
      if (!img.mask[i]) continue;
      if (x + 1 < w && img.mask[i + 1]) {
        edge(i, i + 1, 0.5 * (slope(i, 0) + slope(i + 1, 0)) * pixel_size);
      }
      if (y + 1 < h && img.mask[i + w]) {
        edge(i, i + w, -0.5 * (slope(i, 1) + slope(i + w, 1)) * pixel_size);
      }
    }
  }
  // A small pull toward 0 fixes each region's constant (the Laplacian alone is singular); 1e-8
  // of a pixel's weight moves no slope measurably.
  for (int k = 0; k < count; ++k) triplets.emplace_back(k, k, diagonal[k] + 1e-8);
  Eigen::SparseMatrix<double> a(count, count);
  a.setFromTriplets(triplets.begin(), triplets.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(a);
  if (solver.info() != Eigen::Success) {
    throw Error("", "depth", "integrating the normals failed (the sparse factorisation)");
  }
  const Eigen::VectorXd height = solver.solve(rhs);
  // Each connected region's mean to 0 (the pull leaves them near it, not at it).
  std::vector<int> region(n, -1);
  std::vector<double> sum;
  std::vector<int> size;
  std::vector<std::size_t> stack;
  for (std::size_t s = 0; s < n; ++s) {
    if (!img.mask[s] || region[s] >= 0) continue;
    const int r = static_cast<int>(sum.size());
    sum.push_back(0);
    size.push_back(0);
    stack.push_back(s);
    region[s] = r;
    while (!stack.empty()) {
      const std::size_t i = stack.back();
      stack.pop_back();
      sum[r] += height[unknown[i]];
      ++size[r];
      const int x = static_cast<int>(i % w), y = static_cast<int>(i / w);
      const int nx[4] = {x - 1, x + 1, x, x}, ny[4] = {y, y, y - 1, y + 1};
      for (int k = 0; k < 4; ++k) {
        if (nx[k] < 0 || ny[k] < 0 || nx[k] >= w || ny[k] >= h) continue;
        const std::size_t j = static_cast<std::size_t>(ny[k]) * w + nx[k];
        if (img.mask[j] && region[j] < 0) {
          region[j] = r;
          stack.push_back(j);
        }
      }
    }
  }
  std::vector<double> depth(n, base_depth);
  for (std::size_t i = 0; i < n; ++i) {
    if (!img.mask[i]) continue;
    depth[i] = base_depth - (height[unknown[i]] - sum[region[i]] / size[region[i]]);
  }
  return depth;
}

namespace {

// A file's SHA-256, "" for no file: what the caches of this file key loaded data by.
std::string ContentHash(const std::string& path) {
  return path.empty() || !PathExists(path) ? std::string() : Sha256File(path);
}

}  // namespace

ImageSize NormalImageSize(const std::string& path, const std::string& mask_path,
                          const std::string& variable, bool y_down) {
  const std::string key =
      fmt::format("{}|{}|{}|{}|{}|{}", path, ContentHash(path), mask_path,
                  ContentHash(mask_path), variable, y_down);
  static std::mutex mutex;
  static std::map<std::string, ImageSize> cache;
  {
    std::lock_guard<std::mutex> lock(mutex);
    auto it = cache.find(key);
    if (it != cache.end()) return it->second;
  }
  const NormalImage img = ReadNormalImage(path, mask_path, variable, y_down);
  const ImageSize size{img.width, img.height};
  std::lock_guard<std::mutex> lock(mutex);
  cache.emplace(key, size);
  return size;
}

std::shared_ptr<const PixelSurface> LoadPixelSurface(const NormalMapSpec& spec,
                                                     const Camera& cam) {
  const std::string key = fmt::format(
      "{}|{}|{}|{}|{}|{}|{}|{:.17g},{:.17g},{:.17g}|{:.17g},{:.17g},{:.17g}|{:.17g},{:.17g},{:.17g}|"
      "{:.17g}|{:.17g}|{}x{}",
      spec.normals, ContentHash(spec.normals), ContentHash(spec.mask), ContentHash(spec.depth),
      spec.variable, spec.y_down, static_cast<int>(cam.type), cam.position.x, cam.position.y, cam.position.z,
      cam.look_at.x, cam.look_at.y, cam.look_at.z, cam.up.x, cam.up.y, cam.up.z, cam.fov_y_deg,
      cam.height, cam.width, cam.height_px);
  static std::mutex mutex;
  static std::map<std::string, std::shared_ptr<const PixelSurface>> cache;
  {
    std::lock_guard<std::mutex> lock(mutex);
    auto it = cache.find(key);
    if (it != cache.end()) return it->second;
  }
  const NormalImage img = ReadNormalImage(spec.normals, spec.mask, spec.variable, spec.y_down);
  if (img.width != cam.width || img.height != cam.height_px) {
    throw Error(spec.normals, "normals",
                fmt::format("are {}x{} but the camera's resolution is {}x{}", img.width,
                            img.height, cam.width, cam.height_px));
  }
  Vec3d right, up, forward;
  cam.Basis(&right, &up, &forward);
  const std::size_t n = static_cast<std::size_t>(img.width) * img.height;
  const double distance = Length(cam.look_at - cam.position);
  const double pixel_size = cam.type == Camera::Type::kOrthographic
                                ? cam.height / cam.height_px
                                : 2.0 * distance * std::tan(0.5 * cam.fov_y_deg * kPi / 180.0) /
                                      cam.height_px;
  std::vector<double> depth;
  PixelSurface s;
  if (!spec.depth.empty()) {
    if (!PathExists(spec.depth, "depth")) throw Error(spec.depth, "depth", "file not found");
    const Image d = ReadImage(spec.depth);
    if (d.width != img.width || d.height != img.height) {
      throw Error(spec.depth, "depth", fmt::format("is {}x{} but the normals are {}x{}", d.width,
                                                   d.height, img.width, img.height));
    }
    depth.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      depth[i] = d.data[i * d.channels];
      if (img.mask[i] && !(std::isfinite(depth[i]) && depth[i] > 0)) {
        throw Error(spec.depth, "depth",
                    fmt::format("pixel ({}, {}) is {}: depth must be finite and positive inside "
                                "the mask", i % img.width, i / img.width, depth[i]));
      }
    }
    s.depth_source = "given: " + spec.depth;
  } else {
    if (cam.type != Camera::Type::kOrthographic) {
      throw Error(spec.normals, "depth",
                  "a perspective camera needs a depth map (normals integrate to depth under an "
                  "orthographic view only)");
    }
    depth = IntegrateNormals(img, pixel_size, distance);
    s.depth_source = "integrated from the normals (Poisson)";
  }
  s.width = img.width;
  s.height = img.height;
  s.mask = img.mask;
  s.position.assign(3 * n, 0.0f);
  s.normal.assign(3 * n, 0.0f);
  s.ray_offset = 1.5 * pixel_size;
  for (int y = 0; y < img.height; ++y) {
    for (int x = 0; x < img.width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * img.width + x;
      const Ray ray = CameraRay(cam, x + 0.5, y + 0.5);
      // Depth is along the view axis: the ray's t is depth / cos(ray, forward).
      const Vec3d p = ray.origin + ray.direction * (depth[i] / Dot(ray.direction, forward));
      const Vec3d nc{img.normal[3 * i], img.normal[3 * i + 1], img.normal[3 * i + 2]};
      const Vec3d nw = right * nc.x + up * nc.y - forward * nc.z;
      for (int c = 0; c < 3; ++c) {
        s.position[3 * i + c] = static_cast<float>(p[c]);
        s.normal[3 * i + c] = img.mask[i] ? static_cast<float>(nw[c]) : 0.0f;
      }
    }
  }
  // The depth surface: every 2 x 2 block of masked pixels gives two triangles (one when three
  // are masked), wound counter-clockwise as seen from the camera.
  TriangleMesh mesh;
  mesh.path = spec.normals + " (depth surface)";
  mesh.positions = s.position;
  auto at = [&](int x, int y) { return static_cast<std::uint32_t>(y * img.width + x); };
  for (int y = 0; y + 1 < img.height; ++y) {
    for (int x = 0; x + 1 < img.width; ++x) {
      const std::uint32_t a = at(x, y), b = at(x + 1, y), c = at(x, y + 1), d = at(x + 1, y + 1);
      const bool ma = s.mask[a], mb = s.mask[b], mc = s.mask[c], md = s.mask[d];
      // Image rows run down, so (a, c, b) is counter-clockwise as the camera sees it.
      if (ma && mb && mc) mesh.indices.insert(mesh.indices.end(), {a, c, b});
      if (mb && mc && md) mesh.indices.insert(mesh.indices.end(), {b, c, d});
      if (ma && mb && md && !mc) mesh.indices.insert(mesh.indices.end(), {a, d, b});
      if (ma && mc && md && !mb) mesh.indices.insert(mesh.indices.end(), {a, c, d});
    }
  }
  if (!mesh.indices.empty()) {
    ValidateMesh(mesh.path, &mesh);
    s.depth_mesh = std::make_shared<const TriangleMesh>(std::move(mesh));
  }
  auto shared = std::make_shared<const PixelSurface>(std::move(s));
  std::lock_guard<std::mutex> lock(mutex);
  return cache.emplace(key, shared).first->second;
}

}  // namespace shadefit
