// Parameter charts: for each fitted model of a study, a grid of spheres rendered over its two
// main parameters (GGX: roughness x metallic; Blinn-Phong, classic and normalised: shininess x
// ks) under one light and one exposure, written as PNG files with a manifest the report reads
// (docs/studies.md, "Outputs"). The report marks the fitted materials on them.
#pragma once

#include <string>

#include "shadefit/studies/study.h"

namespace shadefit::studies {

struct ChartSummary {
  int charts = 0;     // Models with a chart (the others have no two main parameters we chart).
  int rendered = 0;   // Spheres rendered this call; 0 when the manifest was up to date.
  double seconds = 0;
};

// Renders the charts of the study's models into <study_dir>/charts/ and writes
// charts/charts.json (schema shadefit.study.charts/1) last, through a temporary file. The light
// is the scene of the first reference lit by "key" (else the first reference with a scene);
// with no scene nothing is written. A manifest with the same content hash (version, models,
// scene bytes) is kept and nothing is rendered. Throws shadefit::Error naming the scene file when
// it cannot be read; without a GL context (a merge node without EGL) prints one line to stderr
// and writes nothing.
ChartSummary WriteParameterCharts(const StudySpec& spec, const std::string& study_dir);

}  // namespace shadefit::studies
