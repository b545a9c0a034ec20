// A reference read from its files: the image, its sidecar JSON (which names the scene), the
// scene TOML and an optional mask. The fitter, the probes and the study runner read references
// through LoadReference; the sidecar's schema lives with the references (reference_images/sidecar.h).
#pragma once

#include <limits>
#include <map>
#include <string>

#include "shadefit/render/image.h"
#include "shadefit/render/scene.h"

namespace shadefit::reference_images {

// How a file's stored values map to linear radiance (the import's --encoding).
enum class Encoding {
  kAuto,    // sRGB for integer files (PNG, JPEG, 8/16-bit TIFF), linear for float files (EXR, HDR)
  kSrgb,    // IEC 61966-2-1 transfer function undone per channel
  kLinear,  // values taken as they are
};
// "auto" | "srgb" | "linear"; throws shadefit::Error("", "encoding", ...) otherwise.
Encoding ParseEncoding(const std::string& name);
std::string EncodingName(Encoding encoding);

// One reference with everything a fit or a probe needs. LoadReference() fills it from files;
// tests and the study runner may fill it in memory (image_path etc. then only name outputs).
struct Reference {
  std::string name;          // Short name used in outputs ("<json stem>.<name>.fit.exr").
  std::string image_path;    // "" for in-memory references.
  std::string sidecar_path;  // "" when none was read.
  std::string scene_path;
  std::string mask_path;     // "" when no mask.
  Image image;               // RGB or RGBA (alpha = coverage), linear radiance.
  Scene scene;
  Image mask;                // Empty, or same size: channel 0 > 0.5 marks pixels to use.
  // How `image` was decoded from the values its source file stored: kSrgb for a display image
  // read here and for an import whose sidecar says "encoding": "srgb"; kLinear otherwise. Applying
  // it forwards gives back the stored values (fit/encoding_search.h compares decodings there).
  Encoding decoded_from = Encoding::kLinear;
  // Pixels with any channel >= clip_level (linear) are excluded: saturated LDR pixels.
  float clip_level = std::numeric_limits<float>::infinity();
  // Measured references (sidecar "measured_domain", written by MakeMeasuredReference): per pixel,
  // the share of its radiance that depends on the BRDF outside the region its data measured
  // (1 channel, in [0, 1], the image's size; reference_images/render_measured.h). Empty for every other
  // reference. A pixel is measured when its share is at most measured_share_max.
  Image extrapolated_share;
  double measured_share_max = 0.0;
  std::string domain_path;  // "" when no domain.
  // Scenes with mesh or normal-map objects: 1 at the pixels on a shadow's edge (ShadowEdgeMask,
  // render/shadows.h), which the renderer cannot reproduce; they are outside the measured domain
  // (IsMeasuredPixel) with that reason. Empty for every other scene.
  Image shadow_edge;
  // Scenes with surface objects whose reference may hold light the objects reflect onto
  // themselves (a photograph, an import, a render with bounces; not one whose sidecar states
  // direct light only, below): 1 at the pixels whose centre's cosine-weighted hemisphere the
  // scene hides by more than kInterreflectionShareMax (SelfOcclusion, render/shadows.h), where
  // interreflection is strong and the renderer (direct light only) cannot reproduce it; they are
  // outside the measured domain with that reason. Empty otherwise.
  Image interreflection;
  // The sidecar states that the image holds direct light only: a Cycles render with
  // max_bounces = 0, a measured render (measured_domain), or "direct_light_only": true.
  bool direct_light_only = false;
  // SHA-256 (hex) of the bytes of every input file read, keyed by role: image, sidecar, scene,
  // mask, domain.
  std::map<std::string, std::string> sha256;
};

// The share of a pixel's cosine-weighted hemisphere hidden by the scene above which its
// interreflection is strong (Reference::interreflection). Measured on Suzanne (red plastic, key
// light) between Cycles with 8 bounces and with none: the light the bounces add is, at the
// median, 2% of the direct light at a share of 0.02-0.05, 4% at 0.05-0.1, 8% at 0.1-0.15, 12% at
// 0.15-0.2 and 18% at 0.2-0.3 (docs/scenes.md, "Shadows").
inline constexpr double kInterreflectionShareMax = 0.1;

// Whether pixel (x, y) lies in the reference's measured domain: not on a shadow's edge, and its
// extrapolated share is at most measured_share_max; every other pixel of a reference without a
// domain does.
bool IsMeasuredPixel(const Reference& ref, int x, int y);

// Reads a reference as the CLI does. The image: EXR/HDR are linear radiance; any other format
// (PNG, JPEG, TIFF: display images) is decoded from sRGB, and pixels with a channel >= 254/255
// before decoding are excluded as clipped. The scene: `scene_override` if not empty, else the
// sidecar `<image path without extension>.json` field "scene_file" (or "scene" when it is a
// string), resolved relative to the sidecar; its "encoding" (imports) sets decoded_from. Mask:
// optional image, channel 0 > 0.5 = use.
// Measured domain: the sidecar's "measured_domain" object, when present, names the domain file
// ("file", relative to the sidecar; 1-channel image, value = extrapolated share) and the threshold
// ("measured_share_max"); both are read into extrapolated_share and measured_share_max.
// Throws shadefit::Error naming the file and field on missing files, bad JSON, a missing scene
// field, a missing, unreadable or malformed domain file (field "measured_domain.file",
// "resolution", "channels" or "pixels"), or a size mismatch between image, scene resolution and
// mask.
Reference LoadReference(const std::string& image_path, const std::string& scene_override = "",
                        const std::string& mask_path = "");

}  // namespace shadefit::reference_images
