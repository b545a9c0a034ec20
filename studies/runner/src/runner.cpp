// The study runner's scheduling (docs/studies.md). The job graph (job_graph.h) is run by worker
// threads that each own a GL context and a Renderer; the job kinds (job_kinds.h) write every
// file through the atomic writer and their JSON last, so a job is done exactly when its JSON
// exists with the job's current hash; the study-wide outputs (outputs.h) are written once every
// job is done.
#include "shadefit/studies/runner.h"

#include <fmt/core.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <thread>

#include <nlohmann/json.hpp>

#include "fit_status.h"
#include "geometry_outputs.h"
#include "job_graph.h"
#include "job_kinds.h"
#include "job_records.h"
#include "outputs.h"
#include "progress_log.h"
#include "run_context.h"
#include "shadefit/metrics/common.h"
#include "shadefit/base/cpus.h"
#include "shadefit/base/error.h"
#include "shadefit/base/files.h"
#include "shadefit/render/gl_context.h"
#include "shadefit/render/renderer.h"
#include "shadefit/version.h"
#include "temporaries.h"

namespace shadefit::studies {
namespace fs = std::filesystem;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

std::string ShadefitVersion() { return SHADEFIT_VERSION_STRING; }

namespace {
using internal::FitStatus;
using internal::Job;

struct Worker {
  std::unique_ptr<GlContext> context;
  std::unique_ptr<Renderer> renderer;

  // A new context and renderer (the first, or after a loss).
  void Reset() {
    renderer.reset();
    context = std::make_unique<GlContext>();
    context->MakeCurrent();
    renderer = std::make_unique<Renderer>(*context);
  }
};

class StudyRun {
 public:
  StudyRun(const StudySpec& spec, const RunOptions& options)
      : spec_(spec),
        options_(options),
        reference_cache_(kReferenceCacheBytes),
        loaded_references_(kReferenceBytes),
        context_{spec_,        options_,           {},         nullptr, &reference_cache_,
                 &reference_previews_, &brdf_fits_, &loaded_references_, &reference_regions_} {}

  RunSummary Run();

 private:
  void Prepare();
  void SkipUpToDate(RunSummary* summary);
  bool UpToDate(const Job& job) const;
  void CheckMergeable() const;
  void RunWorkers(int pending, RunSummary* summary);
  void WorkerLoop(int index);
  Job* NextJobLocked(bool* waiting);
  void ReportStartLocked(const Job& job, int worker, std::unique_lock<std::mutex>& lock);
  struct Tally {
    double done_weight = 0, total_weight = 0;
    int finished = 0, failed = 0;
  };
  Tally TallyLocked() const;
  std::string RunWithGlRetry(Job& job, Worker& worker);
  void FinishLocked(Job& job, const std::string& error, double seconds,
                    std::unique_lock<std::mutex>& lock);
  void Summarise(RunSummary* summary) const;
  void WriteStudyOutputs(bool complete);
  std::string GlRendererForProvenance() const;
  double Elapsed() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }

  // The references' halves of FLIP, CIEDE2000 and Delta E_ITP and their display encodings
  // (16 bytes a pixel): every fit of a material is
  // compared with the same references (10 fits x 7 lightings x ~15 HDR-FLIP exposures in the
  // measured study). A FLIP half is 20 bytes a pixel (CIELAB and ICtCp add 24 each): ~150 MB for
  // a material's 7 references at 256^2 and 15 exposures, so 768 MiB holds about five materials
  // at 256^2 (one at 512^2); the workers share one or two.
  static constexpr std::size_t kReferenceCacheBytes = std::size_t{768} << 20;

  // The references the workers share (loaded_references.h): 1 GiB holds a 96-light set at
  // 612x512 (about 7 MB a reference with its mask and shadow edges) or the measured study's
  // references at 256^2 many times over.
  static constexpr std::size_t kReferenceBytes = std::size_t{1} << 30;

  const StudySpec& spec_;
  RunOptions options_;
  metrics::ReferenceCache reference_cache_;
  internal::WrittenOnce reference_previews_;
  internal::BrdfSpaceFits brdf_fits_;
  internal::ReferenceRegions reference_regions_;
  internal::LoadedReferences loaded_references_;
  internal::RunContext context_;
  std::unique_ptr<internal::Log> log_;
  std::map<std::string, internal::InputHashes> hashes_;  // By reference image path.
  std::vector<Job> jobs_;

  std::mutex mutex_;
  std::condition_variable cv_;
  int running_ = 0;
  Clock::time_point start_;
  std::string gl_renderer_;
  std::string first_error_;
};

void StudyRun::Prepare() {
  const fs::path dir = fs::absolute(fs::path(options_.out_dir) / spec_.name).lexically_normal();
  context_.paths.dir = dir;
  std::error_code ec;
  for (const char* sub : {"jobs", "images", "probes"}) {
    fs::create_directories(dir / sub, ec);
    if (ec) throw Error((dir / sub).string(), "", "cannot create directory: " + ec.message());
  }
  if (!options_.shard.whole()) fs::create_directories(dir / "shards", ec);
  // Temporary files of an interrupted (killed) run: never results. Removed when the process
  // that wrote them is gone; a live one (another run in the same folder) keeps its own. A shard
  // leaves them alone: the folder may be shared with shards on other hosts, whose pids mean
  // nothing here; the merge, which runs after every shard, removes them.
  if (options_.shard.whole() && !options_.merge_only) internal::SweepDeadTemporaries(dir);
  const fs::path log_path = options_.shard.whole()
                                ? dir / "study.log"
                                : dir / "shards" / (options_.shard.Name() + ".log");
  log_ = std::make_unique<internal::Log>(log_path.string(), options_.progress_bar, options_.quiet);
  context_.log = log_.get();
  if (options_.shard.whole()) internal::WriteStudyJson(context_);  // A shard's spec: its part.
  hashes_ = internal::HashInputs(spec_);
}

bool StudyRun::UpToDate(const Job& job) const {
  if (options_.force) return false;
  const std::string path = context_.paths.JobJson(job);
  if (!PathExists(path)) return false;
  try {
    const internal::JobRecordHead head = internal::ReadJobRecordHead(path);
    if (head.hash != job.hash) return false;
    if (head.status == FitStatus::kGlContextLost) return false;  // Retried by every run.
    for (const std::string& out : head.outputs) {
      if (!PathExists((context_.paths.dir / out).string())) return false;
    }
    return true;
  } catch (const Error&) {
    // A record this version cannot read (half written by a killed run, or of an older format):
    // the job runs again and writes a new one.
    return false;
  }
}

void StudyRun::SkipUpToDate(RunSummary* summary) {
  for (Job& job : jobs_) {
    // A job whose inputs were just (re)made runs again: a fit rerun after a lost GL context
    // gives its probes new parameters under the same hash. Dependencies come first in jobs_.
    const bool deps_unchanged = std::all_of(job.deps.begin(), job.deps.end(), [&](int d) {
      return jobs_[d].state == Job::State::kSkipped;
    });
    if (deps_unchanged && UpToDate(job)) {
      job.state = Job::State::kSkipped;
      summary->skipped_ids.push_back(job.id);
      log_->Line("skip " + job.id + " (unchanged)");
    }
  }
}

// A merge runs nothing: every job of the whole graph must be done with its current hash.
void StudyRun::CheckMergeable() const {
  std::vector<const Job*> missing;
  for (const Job& job : jobs_) {
    if (job.state != Job::State::kSkipped) missing.push_back(&job);
  }
  if (missing.empty()) return;
  const Job& first = *missing.front();
  throw Error(context_.paths.JobJson(first), "",
              fmt::format("{} of {} job(s) not done or out of date (first: {}); rerun the shard "
                          "of material '{}'",
                          missing.size(), jobs_.size(), first.id,
                          spec_.groups[first.group].material));
}

void StudyRun::RunWorkers(int pending, RunSummary* summary) {
  const int cpus = UsableCpus();
  int workers = options_.jobs > 0 ? options_.jobs : cpus;
  workers = std::max(1, std::min(workers, pending));
  options_.jobs = workers;
  const std::string part = options_.merge_only      ? " (merge)"
                           : options_.shard.whole() ? ""
                                                    : " (shard " + options_.shard.Name() + ")";
  log_->Say(fmt::format("study {}{}: {} jobs ({} unchanged), {} worker(s), output {}", spec_.name,
                        part, jobs_.size(), summary->skipped_ids.size(), workers,
                        context_.paths.dir.string()));
  if (pending == 0) return;
  // Each worker runs its own metric calls: their row loops get the cores left over, not a
  // thread per core each (which only wait for the cores the other workers use).
  const int metrics_threads_before = metrics::MetricsThreads();
  metrics::SetMetricsThreads(std::max(1, cpus / workers));
  std::vector<std::thread> threads;
  for (int i = 0; i < workers; ++i) threads.emplace_back(&StudyRun::WorkerLoop, this, i);
  for (std::thread& t : threads) t.join();
  metrics::SetMetricsThreads(metrics_threads_before);
  log_->EndBar();
}

// The first pending job whose dependencies are done; probe jobs first (they unblock nothing but
// finish a material's results). Marks jobs whose dependencies failed as not run. `waiting`:
// some pending job waits on a running one.
Job* StudyRun::NextJobLocked(bool* waiting) {
  *waiting = false;
  for (int pass = 0; pass < 2; ++pass) {
    for (Job& job : jobs_) {
      if (job.state != Job::State::kPending) continue;
      if ((pass == 0) != (job.kind == Job::Kind::kProbe)) continue;
      bool ready = true;
      for (int d : job.deps) {
        const Job::State ds = jobs_[d].state;
        if (ds == Job::State::kFailed || ds == Job::State::kNotRun) {
          job.state = Job::State::kNotRun;
          ready = false;
          break;
        }
        if (ds != Job::State::kDone && ds != Job::State::kSkipped) ready = false;
      }
      if (job.state == Job::State::kNotRun) continue;
      if (ready) return &job;
      *waiting = true;
    }
  }
  return nullptr;
}

// The jobs finished (done or failed), failed, and their cost weights, for the progress line.
StudyRun::Tally StudyRun::TallyLocked() const {
  Tally t;
  for (const Job& j : jobs_) {
    t.total_weight += j.weight;
    if (!j.Finished()) continue;
    t.done_weight += j.weight;
    ++t.finished;
    if (j.state == Job::State::kFailed) ++t.failed;
  }
  return t;
}

// Marks `job` running and reports it (log, progress); returns with `lock` released.
void StudyRun::ReportStartLocked(const Job& job, int worker,
                                 std::unique_lock<std::mutex>& lock) {
  const Tally t = TallyLocked();
  const double elapsed = Elapsed();
  lock.unlock();
  log_->Line(fmt::format("start {} (worker {})", job.id, worker));
  log_->Progress(t.done_weight, t.total_weight, t.finished, static_cast<int>(jobs_.size()),
                 t.failed, job.id, elapsed);
}

// Runs the job; "" on success, else the error. A lost GL context: a new context and renderer,
// and the job once more; lost again, the fit is recorded as such (and retried by the next run)
// and the study goes on.
std::string StudyRun::RunWithGlRetry(Job& job, Worker& worker) {
  std::string error;
  for (int attempt = 0; attempt < 2; ++attempt) {
    try {
      if (job.kind == Job::Kind::kFit) internal::RunFitJob(context_, job, *worker.renderer);
      else internal::RunProbeJob(context_, job, jobs_, *worker.renderer);
      worker.context->CheckNotLost();  // Whatever it rendered after a reset is void.
      return "";
    } catch (const GlContextLostError& e) {
      error = e.what();
      log_->Say(fmt::format("{}: {} (attempt {}); new GL context", job.id, error, attempt + 1));
      try {
        worker.Reset();
      } catch (const std::exception& again) {
        return std::string("no new GL context after a loss: ") + again.what();
      }
      if (attempt == 1 && job.kind == Job::Kind::kFit) {
        try {
          internal::WriteFailedFit(context_, job, FitStatus::kGlContextLost, error);
          error.clear();
        } catch (const std::exception& w) {
          error = w.what();
        }
      }
    } catch (const std::exception& e) {
      return e.what();
    }
  }
  return error;
}

// Records the job's end (state, log, progress); called and returns with `lock` held.
void StudyRun::FinishLocked(Job& job, const std::string& error, double seconds,
                            std::unique_lock<std::mutex>& lock) {
  --running_;
  job.state = error.empty() ? Job::State::kDone : Job::State::kFailed;
  const Tally t = TallyLocked();
  const double el = Elapsed();
  lock.unlock();
  if (error.empty()) {
    log_->Line(fmt::format("done {} in {:.1f} s", job.id, seconds));
    if (options_.verbose && !options_.quiet) {
      log_->Say(
          fmt::format("[{}/{}] done {} ({:.1f} s)", t.finished, jobs_.size(), job.id, seconds));
    }
  } else {
    log_->Say(fmt::format("FAILED {}: {}", job.id, error));
  }
  log_->Progress(t.done_weight, t.total_weight, t.finished, static_cast<int>(jobs_.size()),
                 t.failed, "", el);
  lock.lock();
  cv_.notify_all();
}

void StudyRun::WorkerLoop(int index) {
  Worker worker;
  try {
    worker.Reset();
    std::lock_guard lock(mutex_);
    if (gl_renderer_.empty()) gl_renderer_ = worker.context->info().gl_renderer;
  } catch (const std::exception& e) {
    std::lock_guard lock(mutex_);
    if (first_error_.empty()) first_error_ = e.what();
    cv_.notify_all();
    return;
  }
  std::unique_lock lock(mutex_);
  while (true) {
    const bool stop = options_.interrupt != nullptr && options_.interrupt->load();
    bool waiting = false;
    Job* next = stop ? nullptr : NextJobLocked(&waiting);
    if (next == nullptr) {
      // Nothing runnable: stop when interrupted or when nothing waits on a running job.
      if (stop || !waiting) {
        cv_.notify_all();
        return;
      }
      cv_.wait(lock);
      continue;
    }
    next->state = Job::State::kRunning;
    ++running_;
    ReportStartLocked(*next, index, lock);
    const auto t0 = Clock::now();
    const std::string error = RunWithGlRetry(*next, worker);
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    lock.lock();
    FinishLocked(*next, error, seconds, lock);
  }
}

void StudyRun::Summarise(RunSummary* summary) const {
  for (const Job& job : jobs_) {
    switch (job.state) {
      case Job::State::kDone: summary->ran_ids.push_back(job.id); break;
      case Job::State::kFailed: summary->failed_ids.push_back(job.id); break;
      case Job::State::kSkipped: break;
      default: ++summary->not_run; break;
    }
  }
  summary->ran = static_cast<int>(summary->ran_ids.size());
  summary->skipped = static_cast<int>(summary->skipped_ids.size());
  summary->failed = static_cast<int>(summary->failed_ids.size());
  summary->interrupted = options_.interrupt != nullptr && options_.interrupt->load();
  for (const Job& job : jobs_) {
    if (job.kind != Job::Kind::kFit ||
        (job.state != Job::State::kDone && job.state != Job::State::kSkipped)) {
      continue;
    }
    const internal::FitJobRecord fit = internal::ReadFitJobRecord(context_.paths.JobJson(job));
    if (!internal::HasFit(fit.status)) {
      summary->fits_without_parameters.push_back(job.id + ": " +
                                                 internal::FitStatusName(fit.status));
    }
  }
}

// The GL renderer string provenance.json records.
std::string StudyRun::GlRendererForProvenance() const {
  std::string gl = gl_renderer_;
  if (options_.merge_only) {  // The shards' renderers; the merge makes no context.
    std::set<std::string> seen;
    for (const json& m : options_.shard_manifests) {
      const std::string r = m.value("gl_renderer", "");
      if (!r.empty() && seen.insert(r).second) gl += (gl.empty() ? "" : "; ") + r;
    }
    if (gl.empty()) gl = "unknown (every job of every shard was unchanged)";
  }
  if (gl.empty()) {  // Every job was skipped: ask a context for the string anyway.
    try {
      GlContext c;
      gl = c.info().gl_renderer;
    } catch (const std::exception&) {
      gl = "unavailable";
    }
  }
  return gl;
}

void StudyRun::WriteStudyOutputs(bool complete) {
  if (!complete) return;
  if (!options_.shard.whole()) {
    internal::WriteShardManifest(context_, jobs_, gl_renderer_, Elapsed());
    return;
  }
  internal::WriteResultsCsv(context_, jobs_);
  const std::string stages = internal::StageTable(internal::WriteTimingsCsv(context_, jobs_));
  if (!stages.empty()) log_->Say(stages);
  // How often the metrics found a reference's half already computed (the log only: a tuning
  // figure, not a result).
  const metrics::ReferenceCache::Stats cache = reference_cache_.stats();
  log_->Line(fmt::format("reference cache: {} hits, {} misses, {:.0f} MiB held (budget {} MiB)",
                         cache.hits, cache.misses, cache.bytes / 1048576.0,
                         kReferenceCacheBytes >> 20));
  if (internal::WritesGeometry(spec_)) {
    // The data floor's geometry (report/data_floor.py): one G-buffer per reference, on a context
    // of its own (the workers' are gone; a merge never had one).
    GlContext gl;
    gl.MakeCurrent();
    Renderer renderer(gl);
    internal::WriteGeometry(context_, renderer);
  }
  internal::WriteProvenance(context_, jobs_, hashes_, GlRendererForProvenance());
}

RunSummary StudyRun::Run() {
  start_ = Clock::now();
  Prepare();
  jobs_ = internal::BuildJobs(spec_, hashes_);
  RunSummary summary;
  summary.study_dir = context_.paths.dir.string();
  summary.total = static_cast<int>(jobs_.size());
  SkipUpToDate(&summary);
  if (options_.merge_only) {
    CheckMergeable();
    internal::SweepDeadTemporaries(context_.paths.dir);  // Every shard has finished.
  }
  RunWorkers(static_cast<int>(jobs_.size() - summary.skipped_ids.size()), &summary);
  if (!first_error_.empty()) throw Error("", "GL", first_error_);
  Summarise(&summary);
  WriteStudyOutputs(summary.failed == 0 && summary.not_run == 0 && !summary.interrupted);
  summary.seconds = Elapsed();
  log_->Say(fmt::format("study {}: {} ran, {} unchanged, {} failed, {} not run{} in {:.1f} s",
                        spec_.name, summary.ran, summary.skipped, summary.failed, summary.not_run,
                        summary.interrupted ? " (interrupted)" : "", summary.seconds));
  return summary;
}

}  // namespace

RunSummary RunStudy(const StudySpec& spec, const RunOptions& options) {
  StudyRun run(spec, options);
  return run.Run();
}

}  // namespace shadefit::studies
