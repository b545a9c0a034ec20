// Import of published or photographed images as references: decode to linear RGB, mask out
// clipped and user-masked pixels, take coverage from the scene's G-buffer, record counts.
// Optionally find the sphere of a "one sphere on a dark background, orthographic" picture and
// write the matching scene. docs/measured_and_imported.md.
#pragma once

#include <string>
#include <vector>

#include "shadefit/reference_images/reference.h"
#include "shadefit/render/image.h"
#include "shadefit/render/renderer.h"
#include "shadefit/render/scene.h"
#include "shadefit/render/vec.h"

namespace shadefit::reference_images {

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
  std::string found_by;         // "mask", "bright region" or "contrast with the background"
  int contour_points_used = 0;  // silhouette points in the final circle fit
  double fit_rms_px = 0;        // RMS distance of those points from the circle
  bool light_found = false;
  double highlight_x = 0, highlight_y = 0;  // weighted centroid of the brightest blob
  // The blob's pixels (centres) and weights, luminance minus the blob's threshold: a mirror
  // ball's light direction averages the mirror directions of these (light_calibration.h).
  struct HighlightPixel {
    double x, y, weight;
  };
  std::vector<HighlightPixel> highlight_pixels;
  // 8-bit display codes (sRGB of luminance / white) of the brightest pixel on the disc and of
  // the disc's median: a mirror ball's highlight stands far above the rest of the ball.
  double peak_code = 0, median_code = 0;
  Vec3d normal_at_highlight;                // world, scene of OrthographicSphereSceneToml
  Vec3d light_direction;                    // world, unit, from the surface TOWARDS the light
};

// A sphere smaller than this fraction of the picture's shorter side is not taken for the
// sphere: a highlight, a speck or a reflection is (a 9-pixel highlight on a 512x340 photograph
// of a dark mirror ball was, before this rule). 0.05 of 340 px is a 17 px radius.
inline constexpr double kMinSphereRadiusFraction = 0.05;

// Finds one sphere, orthographic view assumed, in one of three ways:
//  - `mask` given (channel 0 > 0.5 = the sphere's pixels): the circle of the mask's largest
//    region, whatever the image shows. A region cut by a straight edge (a stand masked out) is
//    fine: the fit keeps the outer envelope of the outline, so more than half the circle must
//    remain.
//  - else the largest region brighter than the background (a lit sphere on a dark background;
//    the lit part includes at least a half-circle of the silhouette): threshold + largest
//    contour + minimum enclosing circle, then an algebraic least-squares circle fit (Kasa 1976)
//    to the contour points near that circle, which drops the terminator;
//  - else, when that region is smaller than kMinSphereRadiusFraction (a dark ball whose only
//    bright part is its highlight) or reaches two sides of the frame (a room brighter than the
//    ball), the largest region that differs from the background level
//    (median of the picture's border) by more than the border's noise, with the same circle fit.
// The highlight is the connected pixels on the disc (and in the mask) with a luminance of at
// least `highlight_fraction` of the peak's, its centre their centroid weighted by luminance minus
// that threshold (a clipped highlight is a plateau: its centroid is its centre); the light is the
// mirror direction of the view about the sphere normal there.
// `linear` is linear RGB; `white` is the value that maps to full scale for thresholding (1 for
// integer files). Throws shadefit::Error(path, "auto-sphere", ...) when no usable disc is found.
SphereEstimate DetectSphere(const Image& linear, double white, const std::string& path,
                            const Image* mask = nullptr, double highlight_fraction = 0.9);

// The value DetectSphere's thresholds take for full scale: 1 for integer files; for float files a
// high percentile (99.5%) of luminance, so that a few hot pixels do not darken the rest.
double DisplayWhite(const LoadedImage& loaded, const Image& linear);

// `loaded` decoded to linear RGB with `encoding` (kAuto: sRGB for integer files, linear for
// float files); `applied` receives the encoding used (never kAuto).
Image DecodeToLinear(const LoadedImage& loaded, Encoding encoding, Encoding* applied);

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
  // The image holds direct light only (a synthetic render without bounces): the sidecar says
  // so and strong interreflection is not left out (reference.h, Reference::interreflection).
  bool direct_light_only = false;
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

}  // namespace shadefit::reference_images
