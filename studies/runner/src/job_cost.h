// Relative cost estimates of a study's jobs, in units of "one small fit": the progress bar's ETA
// and the shards' balance (AssignShards) use the same numbers.
#pragma once

#include <cstddef>

#include "shadefit/studies/study.h"

namespace shadefit::studies {

// A fit: its starts over the training pixels, then one evaluation (render + every metric) per
// reference of the material.
inline double FitJobCost(const FitSettings& s, std::size_t train_size, std::size_t references) {
  const double pixels_factor = 1.0 / (s.pixel_stride * s.pixel_stride);
  return 1.0 + s.starts * train_size * pixels_factor * 2.0 + 0.5 * references;
}

inline double ProbeJobCost(std::size_t probes) { return 1.0 + 0.5 * probes; }

// Every job of one material with `references` references.
inline double MaterialCost(const StudySpec& spec, std::size_t references) {
  double cost = 0;
  for (const FitSpec& f : spec.Fits()) {
    cost += FitJobCost(spec.SettingsOf(f.model, f.loss), f.train.size(), references);
  }
  if (!spec.probes.empty()) cost += ProbeJobCost(spec.probes.size());
  return cost;
}

}  // namespace shadefit::studies
