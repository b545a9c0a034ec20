// BRDF-space probes: the Fresnel rise, the highlight's shape and the directional albedo read off
// a measured BRDF itself (MERL table or Neural-BRDF network), beside the same quantities of each
// fitted model, in Rusinkiewicz's half/difference angles (Rusinkiewicz 1998;
// reference_images::HalfDiff). The image probes (probes.h) see a BRDF through one scene; these see
// all of it (docs/probes.md, "BRDF-space probes").
//
// Every value is linear luminance Y (probe_common.h, BT.709) of f in 1/sr; models' f is
// Reflect / (n . l) times their exposure (the BRDF a model implies; for the classic models that
// includes their un-normalised lobe as it is). Slices are taken at phi_d = 90 degrees, where l
// and v are mirror images across the plane of n and h: n . l = n . v = cos theta_h cos theta_d,
// so no sample of a slice falls below the horizon.
//
// MERL's gonioreflectometer did not reach theta_d beyond about 75 degrees: the tables hold
// extrapolated values there (Matusik et al. 2003, sec. 5; Burley 2012, sec. 5.1). Every curve
// point and every number that depends on theta_d > extrapolated_theta_d_deg is marked (a
// boolean per point, a fraction per number), never dropped.
#pragma once

#include <vector>

#include "shadefit/probes/probes.h"
#include "shadefit/reference_images/measured_brdf.h"

namespace shadefit::probes {

struct BrdfSpaceOptions {
  // --- Fresnel rise: s(theta_d) = (f(0, theta_d) - floor) cos^2 theta_d, the specular peak
  // times n . l n . v (for a microfacet BRDF D(0) F(theta_d) G(theta_d) / 4: the Smith term's
  // 1 / (4 n.l n.v) divided out, so that the curve rises with F and G only), normalised by its
  // mean over the centre band. Rim/centre ratio = mean over the rim band / mean over the centre.
  double fresnel_step_deg = 1.0;  // theta_d spacing from 0 to fresnel_max_deg (MERL's cells).
  double fresnel_max_deg = 89.0;  // Last theta_d (MERL stores 0..89 degrees).
  double centre_min_deg = 0.0;    // Centre band [centre_min, centre_max] (degrees, inclusive).
  double centre_max_deg = 20.0;
  double rim_min_deg = 70.0;  // Rim band [rim_min, rim_max] (degrees, inclusive).
  double rim_max_deg = 80.0;

  // --- Highlight: f(theta_h, highlight_theta_d, phi_d = 90 deg). 5 degrees: Fresnel is at its
  // normal-incidence value (Schlick's (1 - cos 5 deg)^5 = 1.4e-12) while light and camera do not
  // coincide (theta_d = 0 is retro-reflection, which a gonioreflectometer cannot measure).
  double highlight_theta_d_deg = 5.0;
  int highlight_samples = 361;      // theta_h = (i / (n - 1))^2 * highlight_max_deg: dense at
                                    // the peak like MERL's own square-root spacing (4x finer).
  double highlight_max_deg = 80.0;  // Last theta_h of the curve.
  double floor_min_deg = 30.0;      // Diffuse floor = the smallest f over theta_h in
  double floor_max_deg = 80.0;      // [floor_min, floor_max] on the highlight slice (a wide
                                    // band: measured diffuse is not flat, red-plastic's f has
                                    // its minimum near 45 deg, and a minimum over a wider band
                                    // is never more raised by the lobe's tail).
  double tail_hwhm_multiple = 2.0;  // Tail = theta_h beyond this many HWHM,
  double tail_max_deg = 60.0;       // up to this theta_h (total: 0 to this).

  // --- Energy: directional albedo over view angle theta_o.
  std::vector<double> view_angles_deg = {0, 10, 20, 30, 40, 50, 60, 65, 70, 75, 80, 85, 89};
  int albedo_theta_steps = 256;  // Measured quadrature over the half vector: theta_h steps
  int albedo_phi_steps = 256;    // (square-root spaced) and phi_h steps.
  // DirectionalAlbedo's strata for the models (albedo.h): at 64^2 its RMS error is <= 4.1e-4 of
  // an albedo (BrdfPhysics.AlbedoStandardErrorMatchesItsActualError); 128^2 has four times the
  // samples, far below the 10% of the brdf_albedo verdict.
  int model_strata_per_axis = 128;

  // --- Extrapolation.
  // MERL data beyond this theta_d is extrapolated (reference_images/measured_brdf.h: the rule's one
  // definition, shared with the measured renderer's per-pixel domain).
  double extrapolated_theta_d_deg = reference_images::kMeasuredThetaDMaxDeg;
  // An albedo point is marked extrapolated when more than this fraction of it comes from there.
  double extrapolated_point_fraction = reference_images::kExtrapolatedShareMax;
};

// The three BRDF-space probes of `measured` (series "measured") and of every model (series
// model.label). ProbeResult::probe is "brdf"; numbers, curves and notes as docs/probes.md lists.
// Throws shadefit::Error "<label>: <field>: <problem>" for bad models and "brdf: <option>:
// <problem>" for bad options.
ProbeResult BrdfSpaceProbe(const reference_images::MeasuredBrdf& measured,
                           const std::vector<ModelUnderTest>& models,
                           const BrdfSpaceOptions& options = {});

}  // namespace shadefit::probes
