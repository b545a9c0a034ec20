// Hooks for the interruption and failure-mode tests (docs/testing.md). Unset, each costs one
// getenv per call.
#pragma once

#include <string>

namespace shadefit::studies::internal {

// SHADEFIT_KILL_AT=<site>:<n> (tests/studies/kill_test.sh) kills the process with SIGKILL the
// n-th time it reaches <site>: "fit" (a fit job, after the solve, before any of its outputs),
// "result" (a job's JSON half written to its temporary file, before the rename: WriteJobJson).
void KillPoint(const char* site);

// SHADEFIT_TEST_FAULT=<mode>:<n|*> (tests/studies/fit_failure_test.cpp): true when the n-th (or
// every) fit job attempt is to meet <mode>: "gl-lost" (the context is reported lost when the job
// starts), "nan-residuals" (the solve's cost and parameters come back NaN, as when every
// start's residuals were NaN) or "inf-render" (the n-th evaluation's render of a fit gets one
// infinite pixel, as when a lobe overflows under a lighting it was not trained on). Recording and
// carrying on are the real code paths; only the fault is simulated.
bool FaultArmed(const char* mode);

// A job's JSON, its last file: a job is done exactly when it exists (with the job's hash).
// Written by the atomic writer (base/files.h), with the "result" kill point inside it.
void WriteJobJson(const std::string& path, const std::string& text);

}  // namespace shadefit::studies::internal
