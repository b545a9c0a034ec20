// Directional lights from photographs of a mirror ball (a chrome or dark glossy ball) taken
// under the same lights and camera as the photographs of the object: the light probe of Debevec
// 1998 ("Rendering Synthetic Objects into Real Scenes"), reduced to one distant light per photo,
// the usual calibration of photometric stereo. docs/measured_and_imported.md, "Photographs".
#pragma once

#include <string>
#include <vector>

#include "shadefit/refs/import.h"
#include "shadefit/render/scene.h"
#include "shadefit/render/vec.h"

namespace shadefit::refs {

struct LightCalibrationOptions {
  std::vector<std::string> ball_paths;  // One photograph of the ball per light.
  std::string mask_path;                // Optional: the ball's disc (same for every photo).
  Encoding encoding = Encoding::kAuto;  // Of the ball photographs.
  // The scene of the object's photographs without lights: its camera is the camera of the ball
  // photographs too (the ball may sit anywhere in the frame).
  std::string scene_template;
  std::string output_dir;   // Writes <dir>/<template stem>-<lighting>.toml and <...>-lights.json.
  double irradiance = 1.0;  // Of each light (photographs: exposure unknown, fit it).
  // A highlight must stand this many 8-bit display codes above the ball's median.
  double min_highlight_contrast = 32.0;
};

struct CalibratedLight {
  std::string ball_path;
  std::string lighting;    // The ball file's stem after its first '-' ("ball-l1.png" -> "l1").
  std::string scene_path;  // Written.
  SphereEstimate ball;     // Disc and highlight in pixels.
  Vec3d to_light;          // World, unit: from the surface towards the light.
};

// The light direction of a mirror ball whose disc and highlight `ball` found, seen by `camera`:
// the mirror direction of the view about the ball's normal at the highlight (exact for a
// mirror; for a glossy ball, exact where the lobe is symmetric about the mirror direction),
// averaged over the highlight's pixels with their weights (at its centroid when it has none).
// Orthographic: the normal follows from the highlight's offset from the disc centre. Perspective:
// the ball's centre lies on the ray through the disc centre at 1 / sin(angular radius) ball
// radii, and the normal is where the highlight pixel's ray meets the ball (the projected disc's
// centre is taken for the projection of the ball's centre: off by a second-order term in the
// angular radius).
Vec3d MirrorBallLight(const SphereEstimate& ball, const Camera& camera);

// The whole `shadefit refs lights` command: reads every input, finds each ball and highlight,
// then writes one scene per light (the template's text plus one directional light) and a JSON
// summary, each atomically; a failure leaves no output file. Throws shadefit::Error naming the
// file and field (a ball with no highlight: field "highlight").
std::vector<CalibratedLight> CalibrateLightsFromMirrorBall(const LightCalibrationOptions& options);

}  // namespace shadefit::refs
