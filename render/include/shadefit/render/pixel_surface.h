// Normal-map objects (docs/scenes.md, "Normal-map objects"): per-pixel geometry given as an image
// of normals, a mask and optionally a depth map, aligned with the camera's pixels: the form in
// which photometric-stereo data sets give their ground truth.
//
// Conventions. The normals are in the camera's frame: +x along the image's columns (right), +y up
// the picture (y_axis = "down": along the rows, as some data sets store them), +z toward the
// camera. A visible normal has z > 0; the reader checks that most do and says which axis to flip
// otherwise. Depth, when given, is the distance from the camera along its view axis, in world
// units; without one it is integrated from the normals (a Poisson solve; IntegrateNormals).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "shadefit/render/image.h"
#include "shadefit/render/mesh.h"

namespace shadefit {

struct Camera;

// A 3-channel image of unit normals and its mask as read from a data set's files, before any
// camera is applied.
struct NormalImage {
  int width = 0, height = 0;
  std::vector<float> normal;         // 3 per pixel, camera frame (x right, y up, z to the eye).
  std::vector<std::uint8_t> mask;    // 1 = the object.
};

// Reads normals from .npy (float32/float64, H x W x 3), MATLAB v5/v7.3-less .mat (the variable
// `variable`, or the only H x W x 3 numeric array; compressed or not), .exr / .hdr (float, as
// stored), .png / .tif (16- or 8-bit: 2 v - 1), or text (.txt / .csv: one normal per line, or
// per row of W * 3 numbers, in row-major pixel order; width and height from `mask`, which text
// needs). `y_down`: the file's y runs down the image; it is flipped to up. `mask_path` ("" =
// none): an image whose channel 0 > 0.5 marks the object; without one, every pixel with a
// non-zero normal. Checks: finite values, unit length within 2% inside the mask (8-bit: 5%),
// the mask's size, and that at least 90% of the masked normals face the camera (z > 0).
// Throws shadefit::Error "<file>: <field>: <problem>".
// check_facing = false skips the facing check (a data set's own frame may point z away; the
// import finds the frame first, reference_images/import_set.h).
NormalImage ReadNormalImage(const std::string& path, const std::string& mask_path,
                            const std::string& variable, bool y_down, bool check_facing = true);

// ReadNormalImage's width and height (its checks included), remembered per content of the
// normals and mask files: a data set's scenes (one per light) name the same normals, and a scene
// needs only their size for its camera.
struct ImageSize {
  int width = 0, height = 0;
};
ImageSize NormalImageSize(const std::string& path, const std::string& mask_path,
                          const std::string& variable, bool y_down);

// Writes normals as a .npy of float32, H x W x 3 (0 outside the mask), atomically.
void WriteNormalsNpy(const std::string& path, const NormalImage& normals);

// Depth (distance along the view axis, world units) of every masked pixel from its normals under
// an orthographic camera with square pixels of `pixel_size`: least squares over the mask's edges
// of h(b) - h(a) = the slope the two pixels' normals give, solved by sparse Cholesky (the
// Poisson equation of Horn and Brooks 1986, "The variational approach to shape from shading",
// on the mask's domain rather than Frankot and Chellappa 1988's periodic rectangle, which a
// masked object breaks). Slopes are limited to kMaxIntegratedSlope (|n_z| >= 0.1: at the
// silhouette the normals give no finite height). Each connected region's mean height is
// `base_depth`. Unmasked pixels get base_depth.
constexpr double kMaxIntegratedSlope = 10.0;
std::vector<double> IntegrateNormals(const NormalImage& normals, double pixel_size,
                                     double base_depth);

// The geometry of a normal-map object in world space, for the camera it was read with.
struct PixelSurface {
  int width = 0, height = 0;
  std::vector<std::uint8_t> mask;
  std::vector<float> position;  // 3 per pixel (world), on the camera ray through its centre.
  std::vector<float> normal;    // 3 per pixel (world, unit).
  // Triangles through the masked pixels' positions (two per 2 x 2 block of masked pixels): what
  // casts shadows. Shading normals are the data's, never the triangles'.
  std::shared_ptr<const TriangleMesh> depth_mesh;
  std::string depth_source;  // "given: <file>" or "integrated from the normals (Poisson)"
  double ray_offset = 0;     // Shadow-ray start offset along the normal (1.5 pixel sizes).
  bool Masked(int x, int y) const { return mask[static_cast<std::size_t>(y) * width + x] != 0; }
};

struct NormalMapSpec {
  std::string normals, mask, depth, variable;
  bool y_down = false;
};

// Builds the surface for `camera` (its resolution must be the normals'); cached by files and
// camera. Throws shadefit::Error naming the file and field.
std::shared_ptr<const PixelSurface> LoadPixelSurface(const NormalMapSpec& spec,
                                                     const Camera& camera);

}  // namespace shadefit
