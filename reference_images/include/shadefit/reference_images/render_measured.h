// References rendered with a measured BRDF: the GL renderer's G-buffer (so the camera and the
// ray casting are those of every other render) shaded on the CPU with the measured table or
// network. Point and directional lights are exact per pixel; environment and uniform lights are
// integrated by Monte Carlo with multiple importance sampling. docs/measured_and_imported.md.
#pragma once

#include <cstdint>
#include <string>

#include "shadefit/reference_images/measured_brdf.h"
#include "shadefit/render/gbuffer.h"
#include "shadefit/render/image.h"
#include "shadefit/render/renderer.h"
#include "shadefit/render/scene.h"

namespace shadefit::reference_images {

struct RenderMeasuredOptions {
  // Environment / uniform light: samples per technique per pixel (environment importance
  // sampling + cosine-weighted hemisphere, balance heuristic). 0 takes the light's `samples`.
  int samples = 0;
  // Third technique for glossy and mirror-like BRDFs, which environment and cosine sampling
  // miss: half vectors drawn from a GGX distribution of this width, reflected about wo.
  // < 0: estimated from the BRDF (EstimateLobeAlpha); 0: off.
  double lobe_alpha = -1.0;
  // Seed of the per-pixel random streams; the image does not depend on the thread count.
  std::uint64_t seed = 20240611;
  // Worker threads; 0 = the CPUs this process may use (UsableCpus, shadefit/base/cpus.h).
  int threads = 0;
};

struct RenderMeasuredStats {
  bool environment = false;       // an environment or uniform light was integrated
  int samples_per_technique = 0;  // 0 without one
  double lobe_alpha = 0;          // width of the GGX lobe technique; 0 = not used
  int shaded_pixels = 0;          // pixels with a G-buffer hit
  // Shaded pixels whose extrapolated share is at most kExtrapolatedShareMax (measured_brdf.h);
  // MakeMeasuredReference counts the share as its domain file stores it (steps of 1/255).
  int measured_pixels = 0;
  // Mean over shaded pixels of the per-pixel standard error of the Monte Carlo estimate (RGB,
  // radiance units), and that mean divided by the mean shaded radiance. 0 without environment.
  double mean_standard_error[3] = {0, 0, 0};
  double relative_standard_error = 0;
  double seconds = 0;
  int threads = 0;
  bool ambient_ignored = false;  // the scene has an ambient light (a ka term; no meaning here)
};

// RGBA image: RGB = reflected radiance at each pixel centre times coverage (premultiplied, as the
// GL renderer's output with a transparent film), A = coverage from the G-buffer. With an opaque
// background, uncovered pixels get the background (colour or visible environment) weighted by
// 1 - coverage. `standard_error` (optional) receives the per-pixel standard error, RGB.
//
// `extrapolated_share` (optional, 1 channel) receives, per pixel with a G-buffer hit, the share
// of its radiance that depends on the BRDF outside its measured domain (InMeasuredDomain); 0
// elsewhere. Point and directional lights, exact and independent of the BRDF's values: 1 when
// any light that reaches the pixel (unshadowed, above the horizon of both directions, non-zero
// irradiance) is seen at theta_d beyond the limit, else 0, so that nothing the table holds
// beyond the limit can reach a pixel marked measured. Environment and uniform light: the share of
// the Monte Carlo estimate's luminance (f L cos / pdf, BT.709 Y) that came from samples beyond
// the limit, over the pixel's whole radiance.
Image RenderMeasured(const MeasuredBrdf& brdf, const Scene& scene, const GBuffer& gbuffer,
                     const RenderMeasuredOptions& options, Image* standard_error = nullptr,
                     RenderMeasuredStats* stats = nullptr, Image* extrapolated_share = nullptr);

// The whole `shadefit refs measured` command: loads the BRDF (.binary, or .h5 with its .json
// beside it) and the scene, renders the G-buffer with `renderer`, shades, and writes `output`
// (RGBA EXR), its measured domain (DomainPath(output): the extrapolated share as an 8-bit grey
// PNG, code = round(255 x share)) and its sidecar (output with extension .json, which records
// the domain under "measured_domain"). Everything is computed before anything is written; each
// write is atomic, and a failure removes what was written, so it leaves no output file.
struct MeasuredReferenceRequest {
  std::string brdf_path;
  std::string scene_path;
  std::string output;        // .exr
  std::string noise_output;  // optional: per-pixel standard error EXR
  RenderMeasuredOptions options;
};
RenderMeasuredStats MakeMeasuredReference(const MeasuredReferenceRequest& request,
                                          Renderer& renderer);

// GGX width that stands for the BRDF's specular peak, for importance sampling only (any value
// is unbiased; a close one converges faster): from the half-maximum width of f along theta_h at
// theta_d = 0.1 rad. 0 when f has no peak (ratio to theta_h = 60 degrees below 4).
double EstimateLobeAlpha(const MeasuredBrdf& brdf);

// Sidecar path for an output EXR: the same name with extension .json.
std::string SidecarPath(const std::string& exr_path);

// Measured-domain path for an output EXR: "<stem>.domain.png" beside it (a name an `*.exr` glob
// of a references folder does not pick up).
std::string DomainPath(const std::string& exr_path);

}  // namespace shadefit::reference_images
