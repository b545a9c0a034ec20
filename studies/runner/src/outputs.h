// The study-wide outputs (docs/studies.md, "Outputs"): study.json, results.csv, the per-job
// timing files and timings.csv, provenance.json, and a shard's manifest. Every file goes
// through the atomic writer (base/files.h).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "job_graph.h"
#include "run_context.h"
#include "stage_clock.h"

namespace shadefit::studies::internal {

// study.json: the study as loaded, with shadefit's version.
void WriteStudyJson(const RunContext& context);

// results.csv: one row per fit and reference, from the fit jobs' JSONs; the same bytes on every
// run (no times, no hosts).
void WriteResultsCsv(const RunContext& context, const std::vector<Job>& jobs);

// jobs/<id>.timing.json: the job's wall seconds (the clock's total) and their split into stages
// (stage_clock.h), the fit's solver seconds when >= 0, host and shard. Times are not results:
// they stay out of the job JSON.
void WriteTiming(const RunContext& context, const Job& job, const StageClock& clock,
                 double solver_seconds);

// timings.csv: where the time went, per job and stage, from the timing files. Returns the totals
// per stage (kStageNames' order) of the jobs that ran in this run.
std::vector<double> WriteTimingsCsv(const RunContext& context, const std::vector<Job>& jobs);

// The closing table of `study run`: seconds per stage over the jobs that ran, and their share.
std::string StageTable(const std::vector<double>& totals);

// provenance.json: inputs and their hashes, jobs, versions, machine and run settings.
void WriteProvenance(const RunContext& context, const std::vector<Job>& jobs,
                     const std::map<std::string, InputHashes>& hashes,
                     const std::string& gl_renderer);

// shards/<i>-of-<N>.json, written last by a shard whose every job is done: what the merge needs
// to reload the study, and the shard's provenance.
void WriteShardManifest(const RunContext& context, const std::vector<Job>& jobs,
                        const std::string& gl_renderer, double seconds);

}  // namespace shadefit::studies::internal
