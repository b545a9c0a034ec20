// geometry/: what the report's data floor (report/data_floor.py; docs/measured_and_imported.md,
// "Data floor") needs to fit a tabulated isotropic BRDF without a renderer: per reference, the
// covered pixels with the reference's value and the G-buffer's geometry, and the lights each
// pixel sees (PrepareShading: above the surface, unoccluded, irradiance at normal incidence).
#pragma once

#include "run_context.h"
#include "shadefit/render/renderer.h"

namespace shadefit::studies::internal {

// Whether the study writes geometry/: `[outputs] floor`, whose default is on when any fit has a
// free exposure (the photograph workflow, docs/measured_and_imported.md "Photographs").
bool WritesGeometry(const StudySpec& spec);

// geometry/<reference>.npy per reference of every [[group]] lit by point and directional lights
// only, and geometry/index.json (columns, lights, and why a reference was skipped: environment or
// ambient light). Deterministic bytes; every file through the atomic writer.
void WriteGeometry(const RunContext& context, Renderer& renderer);

}  // namespace shadefit::studies::internal
