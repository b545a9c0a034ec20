// Directional lights from photographs of a mirror ball (a chrome or dark glossy ball) taken
// under the same lights and camera as the photographs of the object: the light probe of Debevec
// 1998 ("Rendering Synthetic Objects into Real Scenes"), reduced to one distant light per photo,
// the usual calibration of photometric stereo. docs/measured_and_imported.md, "Photographs".
#pragma once

#include <string>
#include <vector>

#include "shadefit/reference_images/import.h"
#include "shadefit/render/scene.h"
#include "shadefit/render/vec.h"

namespace shadefit::reference_images {

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
// summary, each atomically; a failure leaves no output file (the output folder is created when
// missing). Throws shadefit::Error naming the file and field (a ball with no highlight: field
// "highlight").
std::vector<CalibratedLight> CalibrateLightsFromMirrorBall(const LightCalibrationOptions& options);

// --- Lights from a published data set (photometric-stereo sets ship their calibration).

// How a data set's axes map onto the camera frame (+x right in the picture, +y up, +z towards
// the viewer: OpenGL's eye space, the frame of Camera::Basis with forward = -z). Entry i says
// which axis of the file, and with which sign, is the camera's axis i: "x,-y,-z" for a data set
// whose y points down the picture and whose z points into the scene.
struct AxisMapping {
  int axis[3] = {0, 1, 2};        // File axis (0 x, 1 y, 2 z) of camera x, y, z.
  double sign[3] = {1, 1, 1};
  std::string text = "x,y,z";     // As given, for the summary.

  Vec3d ToCamera(const Vec3d& file) const;
};
// Parses "x,-y,-z" (three signed axes, each of x, y, z once); throws shadefit::Error on field
// "axes" otherwise.
AxisMapping ParseAxisMapping(const std::string& text);

struct PublishedLightsOptions {
  // One light per line (blank lines and lines starting with '#' skipped): "x y z", the direction
  // from the object towards the light in the data set's axes (any length: normalised), or
  // "x y z r g b" with the light's RGB intensity after it. Commas may separate the numbers.
  std::string directions_path;
  // Optional: one line per light, "r g b" (or one number for a grey light), the same order.
  // Not with a 6-column directions file.
  std::string intensities_path;
  // Optional: one lighting name per line, the same order: a file name keeps its stem after the
  // last '/' ("data/001.png" -> "001"). Default: L0, L1, ... in file order.
  std::string names_path;
  AxisMapping axes;
  std::string scene_template;  // As for the mirror ball: camera and objects, no light.
  std::string output_dir;      // Created when missing.
  // The irradiance of each light is irradiance x its intensity (1 without intensities): the
  // photographs' exposure is fitted, so only the ratios between lights and channels matter.
  double irradiance = 1.0;
};

struct PublishedLight {
  std::string lighting;
  std::string scene_path;  // Written.
  Vec3d to_light;          // World, unit: from the surface towards the light.
  Vec3d irradiance;        // RGB.
};

// `shadefit refs lights --directions`: the same scenes and summary as the mirror-ball path,
// from the data set's own files. Throws shadefit::Error "<file>:<line>: <field>: <problem>" on a
// malformed line, a zero direction, a light pointing away from the camera (behind the object's
// visible side), negative or non-finite intensities and files of different lengths; a failure
// leaves no output file.
std::vector<PublishedLight> LightsFromPublishedFiles(const PublishedLightsOptions& options);

}  // namespace shadefit::reference_images
