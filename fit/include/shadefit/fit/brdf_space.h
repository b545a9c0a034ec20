// Fitting a shading model to a measured BRDF in BRDF space, the way Ngan, Durand and Matusik
// (2005, "Experimental Analysis of BRDF Models", EGSR, section 4) fitted the MERL materials:
// minimise the L2 distance of the cosine-weighted BRDFs over pairs of directions,
//   E^2 = sum_cells w (f(wi, wo) cos theta_i - f_model(wi, wo) cos theta_i)^2 / sum_cells w,
// where w is the cell's measure in (wi, wo) and every cell with theta_i or theta_o beyond a cut
// (80 degrees, as Ngan et al.: MERL's grazing data is unreliable) is left out. An image of a
// sphere under one light sees a thin slice of the BRDF, a few pixels of a sharp highlight; this
// sees all of it, so the lobe widths it finds are comparable with Ngan's published fits.
//
// The cells are those of the MERL parameterisation (Matusik et al. 2003; Rusinkiewicz 1998):
// theta_h square-root spaced (dense at the specular peak), theta_d and phi_d uniform, phi_d over
// [0, pi) (reciprocity gives the rest). With the half/difference change of variables
// dwi dwo = 4 cos theta_d dw_h dw_d, so a cell's weight is
//   w = 4 cos theta_d sin theta_h sin theta_d d(theta_h) d(theta_d) d(phi_d),
// a midpoint rule for the integral over directions whatever the grid's resolution.
//
// Each cell becomes a shading point (normal +z, view wo, one light from wi) whose irradiance is
// sqrt(w') with w' the weight normalised to mean 1: the model's reflected radiance is then
// sqrt(w') f_model cos theta_i and the target sqrt(w') f cos theta_i, so the fitter's own l2
// residuals are the weighted ones above and its RMSE is E per channel. Everything after that is
// Fit()'s: the same solvers, starts, bounds and standard errors (docs/fitting.md).
#pragma once

#include <string>
#include <vector>

#include "shadefit/fit/fit_types.h"
#include "shadefit/reference_images/measured_brdf.h"
#include "shadefit/render/gbuffer.h"

namespace shadefit::fit {

struct BrdfSpaceSampling {
  int theta_h_cells = 90;       // MERL's 90 square-root-spaced theta_h cells
  int theta_d_cells = 45;       // over [0, 90) degrees (MERL: 90)
  int phi_d_cells = 45;         // over [0, 180) degrees (MERL: 180)
  double max_theta_deg = 80.0;  // incident and outgoing cut (Ngan et al. 2005)
};

// Throws shadefit::Error naming `field` ("brdf_space.theta_h_cells", ...) when a count is below
// 2 or above 1024 or the cut is outside (0, 90) degrees.
void ValidateBrdfSpaceSampling(const BrdfSpaceSampling& s, const std::string& file);

// The measured BRDF on those cells, ready to be fitted.
struct BrdfSpaceData {
  std::string label;                // The BRDF's first file, for messages and the JSON.
  std::vector<std::string> files;   // Every file it was read from.
  std::vector<std::string> sha256;  // Of each file, in the same order.
  std::string format;               // "merl-binary" or "neural-brdf".
  BrdfSpaceSampling sampling;
  std::vector<ShadingPoint> points;  // One per kept cell (irradiance sqrt(w')).
  std::vector<double> targets;       // 3 per point: sqrt(w') f cos theta_i, linear.
  std::vector<double> weights;       // w' per point (mean 1).
  double extrapolated_fraction = 0;  // Weight share of cells with theta_d > 75 degrees (MERL
                                     // extrapolates there; docs/probes.md).
};

// Samples `brdf` on the cells (multi-threaded, deterministic: the same bytes for any thread
// count). Throws shadefit::Error when the BRDF is non-finite or negative on a kept cell, or zero
// on all of them.
BrdfSpaceData SampleBrdfSpace(const reference_images::MeasuredBrdf& brdf,
                              const BrdfSpaceSampling& sampling);

// The options a BRDF-space fit accepts (below); throws shadefit::Error otherwise.
void CheckBrdfSpaceOptions(const FitOptions& options);

// Fits `model` to the sampled BRDF (taken by value: its cells become the fit's points; pass an
// rvalue to avoid a copy). options as for Fit(); the loss must be l2 (the weights are
// those of an L2 norm) and the exposure fixed (a BRDF has no unknown scale), else
// FitOptionError (loss, exposure). No GL context is created or used (render_outputs
// and the renderer are ignored). The result's one reference is named "brdf-space"; its rmse is E
// above and FitResult::inputs records the files, their SHA-256 and the sampling.
FitResult FitBrdfSpace(const ModelInfo& model, const std::vector<FixedValue>& fixed,
                       BrdfSpaceData data, const FitOptions& options = {});

}  // namespace shadefit::fit
