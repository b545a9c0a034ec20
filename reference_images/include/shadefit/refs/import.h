// Import of published or photographed images as references: decode to linear RGB, mask out
// clipped and user-masked pixels, take coverage from the scene's G-buffer, record counts.
// Optionally find the sphere of a "one sphere on a dark background, orthographic" picture and
// write the matching scene. docs/measured_and_imported.md.
#pragma once

#include <string>

#include "shadefit/render/image.h"
#include "shadefit/render/renderer.h"
#include "shadefit/render/scene.h"
#include "shadefit/render/vec.h"

namespace shadefit::refs {

enum class Encoding {
  kAuto,    // sRGB for integer files (PNG, JPEG, 8/16-bit TIFF), linear for float files (EXR, HDR)
  kSrgb,    // IEC 61966-2-1 transfer function undone per channel
  kLinear,  // values taken as they are
};
// "auto" | "srgb" | "linear"; throws shadefit::Error("", "encoding", ...) otherwise.
Encoding ParseEncoding(const std::string& name);
std::string EncodingName(Encoding encoding);

// An input image with what the import needs to know about its file.
struct LoadedImage {
  Image rgb;              // 3 channels, values as stored ([0, 1] for integer files)
  bool is_float = false;  // float/half file: no clipping rule, linear by default
  std::string format;     // OpenImageIO's file format and data type, e.g. "jpeg uint8"
  int file_channels = 0;  // 1, 3 or 4 (alpha ignored)
};
// Reads and validates an image for import. Throws shadefit::Error "<path>: <field>: <problem>"
// (fields: image, pixels, channels) for a missing, truncated or corrupt file (including JPEG and
// PNG files cut short, which decoders otherwise fill silently), NaN or Inf values, and channel
// counts other than 1, 3 or 4.
LoadedImage LoadImageForImport(const std::string& path);

// Result of DetectSphere, in pixel units with our conventions (row 0 on top, pixel (i, j) has its
// centre at (i + 0.5, j + 0.5)).
struct SphereEstimate {
  double center_x = 0, center_y = 0, radius = 0;
  int contour_points_used = 0;  // silhouette points in the final circle fit
  double fit_rms_px = 0;        // RMS distance of those points from the circle
  bool light_found = false;
  double highlight_x = 0, highlight_y = 0;  // centroid of the brightest blob
  Vec3d normal_at_highlight;                // world, scene of OrthographicSphereSceneToml
  Vec3d light_direction;                    // world, unit, from the surface TOWARDS the light
};

// Finds one sphere on a dark background (assumptions: the background is darker than every lit
// part of the sphere, the sphere is the largest bright region, the view is orthographic, the lit
// part includes at least a half-circle of the silhouette). Threshold + largest contour +
// minimum enclosing circle, then an algebraic least-squares circle fit (Kasa 1976) to the contour
// points near that circle, which drops the terminator; the highlight is the centroid of the
// connected pixels within 90% of the peak luminance; the light is the mirror direction of the
// view about the sphere normal there. `linear` is linear RGB; `white` is the value that maps to
// full scale for thresholding (1 for integer files). Throws shadefit::Error(path, "auto-sphere",
// ...) when no usable disc is found.
SphereEstimate DetectSphere(const Image& linear, double white, const std::string& path);

// Scene TOML (docs/scenes.md) for a unit sphere at the origin seen by an orthographic camera on
// -Y, framed so that the sphere projects to the estimate's circle, with the estimated light as a
// directional light of irradiance 1 (exposure is unknown).
std::string OrthographicSphereSceneToml(const SphereEstimate& sphere, int width, int height,
                                        const std::string& source_name);

struct ImportOptions {
  std::string image_path;
  std::string scene_path;  // required unless auto_sphere
  std::string mask_path;   // optional: non-zero first channel = valid
  Encoding encoding = Encoding::kAuto;
  int clip_threshold = 254;  // 8-bit code; any channel >= threshold / 255 is excluded
  bool auto_sphere = false;  // write <output>.toml from DetectSphere and use it
  std::string output;        // .exr; the sidecar is <output>.json
};

struct ImportCounts {
  long long total = 0;          // pixels in the image
  long long masked_out = 0;     // invalid in the user's mask
  long long clipped = 0;        // not masked out, but a channel >= threshold (integer files)
  long long valid = 0;          // total - masked_out - clipped
  long long covered = 0;        // coverage > 0 in the scene's G-buffer
  long long valid_covered = 0;  // valid and covered: the pixels a fit uses
};

struct ImportResult {
  Image image;  // RGBA: linear RGB x validity, A = validity x coverage
  ImportCounts counts;
  Encoding encoding = Encoding::kAuto;  // the one applied (never kAuto)
  bool has_sphere = false;
  SphereEstimate sphere;
  std::string scene_path;  // the scene used (written beside the output with auto_sphere)
};

// The whole `shadefit refs import` command: reads and validates every input, renders the scene's
// G-buffer with `renderer`, then writes the EXR, the sidecar JSON and (auto_sphere) the scene
// TOML, each atomically; a failure leaves no output file.
ImportResult ImportReference(const ImportOptions& options, Renderer& renderer);

}  // namespace shadefit::refs
