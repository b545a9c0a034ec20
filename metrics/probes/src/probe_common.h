// Shared machinery of the probes: input checks, model renders, and the split of an image into a
// diffuse estimate and a specular residual with the per-pixel angles (docs/probes.md).
#pragma once

#include <nlohmann/json.hpp>
#include <limits>
#include <string>
#include <vector>

#include "shadefit/probes/probes.h"
#include "shadefit/render/gbuffer.h"
#include "shadefit/render/models.h"

namespace shadefit::probes::internal {

// Linear luminance of Rec. 709 RGB (ITU-R BT.709-6).
inline double Luma(double r, double g, double b) { return 0.2126 * r + 0.7152 * g + 0.0722 * b; }

inline constexpr double kRadToDeg = 57.29577951308232;
// What a probe reports for a quantity it could not measure (JSON null on output).
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Throws shadefit::Error "<label>: <field>: <problem>" for an unknown model, a wrong parameter
// count, non-finite or out-of-table parameters, or a non-positive exposure.
const ModelInfo& ValidateModel(const ModelUnderTest& model);

// The model under the reference's scene: GL render times exposure when a renderer is given,
// else the C++ twin (throws when the scene needs GL). RGBA, alpha = coverage.
Image RenderModel(const ProbeInputs& inputs, const ModelUnderTest& model,
                  const ProbeReference& reference);

// The diffuse term (with the ambient term for models that have ka) and, per light, the
// unit-Fresnel specular lobe (the model's specular term with F = 1 and unit specular
// coefficient, times irradiance: luminance) at one shading point.
void DiffuseAndLobe(ModelId id, const double* params, const ShadingPoint& point,
                    double diffuse_rgb[3], std::vector<double>* lobe_per_light);

// One pixel of an image split into diffuse estimate and specular residual (luminance).
struct PixelTerms {
  int x = 0, y = 0;
  double theta_v_deg = 0;   // acos(n.v)
  double theta_h_deg = -1;  // acos(n.h) for the dominant light; -1 when no light reaches it
  double theta_d_deg = -1;  // acos(l.h) for the dominant light; -1 when no light reaches it
  double total = 0;         // Y of the image
  double diffuse = 0;       // Y of the diffuse estimate
  double specular = 0;      // total - diffuse (may be slightly negative: noise)
  double lobe = 0;          // Y of the unit-Fresnel lobe (0 when unknown)
};

struct Decomposition {
  std::vector<PixelTerms> pixels;
  bool has_lobe = false;
  std::string diffuse_source;  // "truth", "model", "lambert-percentile (kd = ...)"
};

// The angles a decomposition reports at each shading point: theta_v, and theta_h and theta_d
// under each of the point's lights (whichever is dominant in an image). They depend on the
// point alone, so a reference's are computed once and shared by the decompositions of the
// reference and of every model under it (three acos per pixel and image before).
struct ShadingAngles {
  std::vector<double> theta_v_deg;         // per point
  std::vector<std::size_t> first_light;    // per point, and one past the last: its lights' entries
  std::vector<double> theta_h_deg, theta_d_deg;  // per point and light
};
ShadingAngles AnglesOf(const std::vector<ShadingPoint>& points);

// Pixels of `points` whose image coverage (alpha when present) is >= min_coverage. `angles`:
// AnglesOf(points). `known`: the BRDF whose diffuse term (times its exposure) is subtracted and
// whose lobe is reported; null: the Lambert-percentile estimate.
Decomposition Decompose(const std::vector<ShadingPoint>& points, const ShadingAngles& angles,
                        const Image& image, const ModelUnderTest* known, double min_coverage,
                        double diffuse_percentile);

// The references a probe uses: `lightings` (empty: all) whose scene the twin supports; the
// others are named in `notes`.
std::vector<const ProbeReference*> SelectTwinReferences(const ProbeInputs& inputs,
                                                        const std::vector<std::string>& lightings,
                                                        std::vector<std::string>* notes);

// A JSON number, or null when not finite.
nlohmann::json Num(double v);

}  // namespace shadefit::probes::internal
