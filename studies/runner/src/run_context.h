// What every unit of a run reads: the study, the options, where the files go and the log.
#pragma once

#include "job_graph.h"
#include "shadefit/metrics/flip.h"
#include "progress_log.h"
#include "shadefit/studies/runner.h"
#include "shadefit/studies/study.h"

namespace shadefit::studies::internal {

struct RunContext {
  const StudySpec& spec;
  const RunOptions& options;
  StudyPaths paths;
  Log* log = nullptr;
  // Shared by the workers; may be null (metrics are the same without it).
  metrics::FlipReferenceCache* flip_cache = nullptr;
};

}  // namespace shadefit::studies::internal
