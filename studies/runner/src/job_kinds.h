// The two kinds of job (docs/studies.md, "Jobs"): a fit (fit_job.cpp) and a material's probes
// (probe_job.cpp). Each writes its outputs through the atomic writer and its JSON last.
#pragma once

#include <string>
#include <vector>

#include "fit_status.h"
#include "job_graph.h"
#include "run_context.h"
#include "shadefit/render/renderer.h"

namespace shadefit::studies::internal {

// One Ceres thread per fit: a fit's sums then run in one fixed order, so its numbers are the
// same bytes for any -j, any shard count and any machine load (the runner parallelises over
// jobs instead; docs/studies.md, "Determinism").
inline constexpr int kCeresThreadsPerFit = 1;

// Fits the job's model to its training references, evaluates the fit under every lighting of
// the material (metrics, previews) and writes jobs/<id>.json. A degenerate reference or NaN
// residuals are recorded as the fit's status (WriteFailedFit), not thrown. Throws
// GlContextLostError when the context is lost, shadefit::Error on bad input.
void RunFitJob(const RunContext& context, const Job& job, Renderer& renderer);

// A fit that left no parameters: recorded with its status and message, no evaluations; the
// material's probes go on without it and results.csv gives it a row per reference with empty
// metrics.
void WriteFailedFit(const RunContext& context, const Job& job, FitStatus status,
                    const std::string& error);

// Runs the study's probes on the material's references and the fits its dependencies left
// (`jobs`: the whole graph) and writes probes/<material>/ and jobs/<id>.json.
void RunProbeJob(const RunContext& context, const Job& job, const std::vector<Job>& jobs,
                 Renderer& renderer);

}  // namespace shadefit::studies::internal
