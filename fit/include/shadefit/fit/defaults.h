// The fitter's defaults that the CLI (`shadefit fit`) and the study runner (FitSettings) share:
// one definition, so that a study without a `starts` key fits as `shadefit fit` does. A header
// of its own, without dependencies, because study.h includes it.
#pragma once

namespace shadefit::fit {

// Starts per fit (start 0 = the table defaults, then scrambled Halton points; docs/fitting.md,
// "Multi-start"). On references with more than 16384 valid pixels every start runs on a
// ~4096-pixel subsample and only those within 1% of the best are polished on all pixels, so
// extra starts cost about a coarse fit each. 4, not 1: one start can end in a KKT point of the
// box, not the optimum (measured, bounded LM, one start: black-glossy-mirror85 stops with every
// specular scale on its floor at cost 3.7e6 against 1.5; BENCHMARKS.md at 26b8abd, in git), and
// the MERL materials that stopped at the roughness floor with one start were
// found with 4.
inline constexpr int kDefaultStarts = 4;
inline constexpr int kDefaultMaxIterations = 100;  // Per start.

}  // namespace shadefit::fit
