// The study runner (docs/studies.md). Jobs form a small DAG: fit jobs (material x model x
// training set; each also evaluates the fit under every lighting of its material) and probe
// jobs (one per material, after all of that material's fits). Workers each own a GL context and
// a Renderer; a job writes every file through a temporary name and a rename, and its JSON last,
// so a job is done exactly when its JSON exists with the job's current hash.
#include "shadefit/studies/runner.h"

#include <fmt/chrono.h>
#include <fmt/core.h>
#include <sys/utsname.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <deque>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include <ceres/version.h>
#include <OpenImageIO/oiioversion.h>
#include <opencv2/core/version.hpp>

#include "shadefit/fit/fitter.h"
#include "shadefit/metrics/false_color.h"
#include "shadefit/metrics/report.h"
#include "shadefit/render/error.h"
#include "shadefit/render/files.h"
#include "shadefit/render/gl_context.h"
#include "shadefit/render/image.h"
#include "shadefit/render/models.h"
#include "shadefit/render/renderer.h"
#include "shadefit/probes/probes.h"
#include "job_cost.h"
#include "sidecar_scene.h"

#ifndef SHADEFIT_VERSION_STRING
#define SHADEFIT_VERSION_STRING "unknown"
#endif

namespace shadefit::studies {
namespace fs = std::filesystem;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

std::string ShadefitVersion() { return SHADEFIT_VERSION_STRING; }

void WriteFileAtomic(const std::string& path, const std::string& text) {
  shadefit::WriteTextAtomic(path, text);
}

namespace {

// A test hook for the interruption tests (tests/studies/kill_test.sh, docs/testing.md):
// SHADEFIT_KILL_AT=<site>:<n> kills the process with SIGKILL the n-th time it reaches <site>:
// "fit" (a fit job, after the solve, before any of its outputs), "result" (a job's JSON half
// written to its temporary file, before the rename). Unset, it costs one getenv per job.
bool KillPointArmed(const char* site) {
  static const std::string spec = [] {
    const char* v = std::getenv("SHADEFIT_KILL_AT");
    return std::string(v != nullptr ? v : "");
  }();
  if (spec.empty()) return false;
  const auto colon = spec.find(':');
  if (spec.substr(0, colon) != site) return false;
  static std::atomic<int> reached{0};
  const int n = colon == std::string::npos ? 1 : std::atoi(spec.c_str() + colon + 1);
  return ++reached == n;
}

void KillPoint(const char* site) {
  if (KillPointArmed(site)) ::kill(::getpid(), SIGKILL);
}

// Fault injection for the failure-mode tests (tests/studies/fit_failure_test.cpp):
// SHADEFIT_TEST_FAULT=<mode>:<n|*> makes the n-th (or every) fit job attempt meet <mode>:
// "gl-lost" (the context is reported lost when the job starts) or "nan-residuals" (the solve's
// cost and parameters come back NaN, as when every start's residuals were NaN). Recording and
// carrying on are the real code paths; only the fault is simulated.
bool FaultArmed(const char* mode) {
  static std::mutex mutex;
  static std::string last;
  static int reached = 0;
  const char* v = std::getenv("SHADEFIT_TEST_FAULT");
  const std::string spec = v != nullptr ? v : "";
  std::lock_guard lock(mutex);
  if (spec != last) {  // A new fault (tests set one per run): count from zero.
    last = spec;
    reached = 0;
  }
  const auto colon = spec.find(':');
  if (spec.empty() || spec.substr(0, colon) != mode) return false;
  const std::string n = colon == std::string::npos ? "1" : spec.substr(colon + 1);
  ++reached;
  return n == "*" || reached == std::atoi(n.c_str());  // "*": every time.
}

// A fit job's outcome, in results.csv's `status` column and the job JSON. The last three leave
// no fitted parameters; the study carries on without that fit.
constexpr const char* kStatusOk = "ok";
constexpr const char* kStatusNotConverged = "not-converged";
constexpr const char* kStatusDegenerate = "degenerate-reference";
constexpr const char* kStatusNan = "nan-residuals";
constexpr const char* kStatusGlLost = "gl-context-lost";

bool HasFit(const std::string& status) {
  return status == kStatusOk || status == kStatusNotConverged;
}

// A job's JSON, its last file: a job is done exactly when it exists (with the job's hash).
void WriteJobJson(const std::string& path, const std::string& text) {
  if (KillPointArmed("result")) {
    std::ofstream(TemporaryPathFor(path), std::ios::binary) << text.substr(0, text.size() / 2);
    ::kill(::getpid(), SIGKILL);
  }
  WriteFileAtomic(path, text);
}

// ---------------------------------------------------------------------------------------------
// Inputs and jobs

struct InputHashes {
  std::string image, sidecar, scene, scene_path;
};

struct Job {
  enum class Kind { kFit, kProbe };
  Kind kind = Kind::kFit;
  std::string id;           // File-name safe: "fit.red-plastic.ggx.key", "probe.red-plastic".
  int group = 0;            // Index into spec.groups.
  std::string model, label;
  std::vector<std::string> train;
  std::vector<int> deps;    // Job indices.
  std::string hash;
  double weight = 1;        // Relative cost estimate for the ETA.
  enum class State { kPending, kRunning, kDone, kSkipped, kFailed, kNotRun } state = State::kPending;
};

std::string JoinTrain(const std::vector<std::string>& train) {
  std::string s;
  for (std::size_t i = 0; i < train.size(); ++i) s += (i ? "+" : "") + train[i];
  return s;
}

std::string FileSafe(std::string s) {
  for (char& c : s) {
    if (c == '/' || c == ' ' || c == '\\') c = '_';
  }
  return s;
}

// The sidecar's material as the cycles-principled (or lambert) model: the ground truth the
// probes may compare against. Empty when the material has no exact twin.
std::optional<std::pair<std::string, std::vector<double>>> TruthOfSidecar(
    const std::string& sidecar) {
  if (sidecar.empty()) return std::nullopt;
  std::ifstream in(sidecar);
  try {
    const json j = json::parse(in);
    if (!j.contains("material")) return std::nullopt;
    const json& m = j["material"];
    const std::string type = m.value("type", "");
    if (type == "principled" && m.value("distribution", "GGX") == "GGX") {
      const auto& c = m["base_color"];
      return std::make_pair(std::string("cycles-principled"),
                            std::vector<double>{c[0], c[1], c[2], m.value("metallic", 0.0),
                                                m.value("specular", 0.5),
                                                std::max(0.01, m.value("roughness", 0.5))});
    }
    if (type == "diffuse" && m.value("roughness", 0.0) == 0.0) {
      const auto& c = m["base_color"];
      return std::make_pair(std::string("lambert"), std::vector<double>{c[0], c[1], c[2]});
    }
  } catch (const json::exception&) {
  }
  return std::nullopt;
}

// ---------------------------------------------------------------------------------------------
// Logging and progress

class Log {
 public:
  Log(const std::string& path, bool bar, bool quiet)
      : out_(path, std::ios::app), bar_(bar), quiet_(quiet) {}

  void Line(const std::string& text) {
    std::lock_guard lock(mutex_);
    out_ << Timestamp() << "  " << text << "\n";
    out_.flush();
  }
  // Also to stderr (cleared bar first).
  void Say(const std::string& text) {
    Line(text);
    if (quiet_) return;
    std::lock_guard lock(mutex_);
    if (bar_) std::fputs("\r\033[K", stderr);
    std::fprintf(stderr, "%s\n", text.c_str());
    if (bar_) DrawLocked();
  }
  void Progress(double done_weight, double total_weight, int done, int total,
                const std::string& current, double elapsed) {
    std::lock_guard lock(mutex_);
    done_weight_ = done_weight;
    total_weight_ = total_weight;
    done_ = done;
    total_ = total;
    current_ = current;
    elapsed_ = elapsed;
    if (bar_ && !quiet_) DrawLocked();
  }
  void EndBar() {
    std::lock_guard lock(mutex_);
    if (bar_ && !quiet_) std::fputs("\r\033[K", stderr);
  }

 private:
  static std::string Timestamp() {
    const std::time_t t = std::time(nullptr);
    std::tm tm{};
    localtime_r(&t, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S", &tm);
    return buf;
  }
  void DrawLocked() {
    const int width = 28;
    const double f = total_weight_ > 0 ? std::clamp(done_weight_ / total_weight_, 0.0, 1.0) : 0;
    const int filled = static_cast<int>(std::round(f * width));
    std::string eta = "--:--";
    if (f > 0.02 && f < 1) {
      const int s = static_cast<int>(elapsed_ * (1 - f) / f);
      eta = fmt::format("{}:{:02d}", s / 60, s % 60);
    }
    std::string current = current_.size() > 48 ? current_.substr(0, 45) + "..." : current_;
    std::fprintf(stderr, "\r\033[K[%s%s] %d/%d  ETA %s  %s", std::string(filled, '#').c_str(),
                 std::string(width - filled, '-').c_str(), done_, total_, eta.c_str(),
                 current.c_str());
    std::fflush(stderr);
  }

  std::mutex mutex_;
  std::ofstream out_;
  bool bar_, quiet_;
  double done_weight_ = 0, total_weight_ = 0, elapsed_ = 0;
  int done_ = 0, total_ = 0;
  std::string current_;
};

// ---------------------------------------------------------------------------------------------
// The run

struct Worker {
  std::unique_ptr<GlContext> context;
  std::unique_ptr<Renderer> renderer;
};

class StudyRun {
 public:
  StudyRun(const StudySpec& spec, const RunOptions& options) : spec_(spec), options_(options) {}

  RunSummary Run();

 private:
  void Prepare();
  void SweepDeadTemporaries(std::vector<fs::path>* stale);
  void BuildJobs();
  bool UpToDate(const Job& job) const;
  void WorkerLoop(int index);
  void RunFitJob(Job& job, Worker& worker);
  void RunProbeJob(Job& job, Worker& worker);
  void WriteFailedFit(const Job& job, const std::string& status, const std::string& error);
  json FitJobHeader(const Job& job, const std::string& status) const;
  void WriteResultsCsv();
  void WriteProvenance(const std::string& gl_renderer);
  std::string JobPath(const Job& job) const { return (dir_ / "jobs" / (job.id + ".json")).string(); }
  std::string TimingPath(const Job& job) const {
    return (dir_ / "jobs" / (job.id + ".timing.json")).string();
  }
  void WriteTiming(const Job& job, double seconds, double solver_seconds);
  void WriteTimingsCsv();
  void WriteShardManifest(double seconds);
  void CheckMergeable() const;
  std::string HostName() const;
  double ErrorScale(const fit::FitReference& ref) const;

  const StudySpec& spec_;
  RunOptions options_;
  fs::path dir_;
  std::map<std::string, InputHashes> hashes_;  // By reference image path.
  std::vector<Job> jobs_;
  std::unique_ptr<Log> log_;
  static constexpr int kCeresThreadsPerFit = 1;

  std::mutex mutex_;
  std::condition_variable cv_;
  int running_ = 0;
  Clock::time_point start_;
  std::string gl_renderer_;
  std::string first_error_;
};

// Hidden temporaries are named "<dir>/.<name>.<pid>.<n>.tmp" (TemporaryPathFor, render/files.h),
// ".<probe>.<pid>.tmp.<ext>" (the probes' plot files) or ".<name>.<pid>.tmp" (the report's). True when `leaf` is one of them and no
// process with that pid is running.
bool IsTemporaryOfDeadProcess(const std::string& leaf) {
  if (leaf.size() < 6 || leaf[0] != '.') return false;
  std::vector<std::string> parts;
  std::size_t start = 1;
  while (true) {
    const std::size_t dot = leaf.find('.', start);
    parts.push_back(leaf.substr(start, dot == std::string::npos ? std::string::npos : dot - start));
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  auto numeric = [](const std::string& x) {
    return !x.empty() && x.size() < 10 &&
           std::all_of(x.begin(), x.end(), [](char c) { return c >= '0' && c <= '9'; });
  };
  const std::size_t n = parts.size();
  long pid = -1;
  if (n >= 4 && parts[n - 1] == "tmp" && numeric(parts[n - 2]) && numeric(parts[n - 3])) {
    pid = std::stol(parts[n - 3]);
  } else if (n >= 4 && parts[n - 2] == "tmp" && numeric(parts[n - 3])) {
    pid = std::stol(parts[n - 3]);
  } else if (n >= 3 && parts[n - 1] == "tmp" && numeric(parts[n - 2])) {
    pid = std::stol(parts[n - 2]);  // ".<name>.<pid>.tmp": the report's (report/*.py).
  }
  if (pid <= 0) return false;
  if (::kill(static_cast<pid_t>(pid), 0) != 0) return errno == ESRCH;
  // A killed process stays a zombie until its parent (or init, for an orphan) reaps it: dead,
  // though kill(pid, 0) still finds it. /proc/<pid>/stat's third field is then Z (or X).
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return false;
  const auto paren = line.rfind(')');  // The command name may hold spaces and parentheses.
  return paren != std::string::npos && paren + 2 < line.size() &&
         (line[paren + 2] == 'Z' || line[paren + 2] == 'X');
}

void StudyRun::SweepDeadTemporaries(std::vector<fs::path>* stale) {
  for (const auto& entry : fs::recursive_directory_iterator(dir_)) {
    if (entry.is_regular_file() && IsTemporaryOfDeadProcess(entry.path().filename().string())) {
      stale->push_back(entry.path());
    }
  }
  std::error_code ec;
  for (const fs::path& p : *stale) fs::remove(p, ec);
}

void StudyRun::Prepare() {
  dir_ = fs::absolute(fs::path(options_.out_dir) / spec_.name).lexically_normal();
  std::error_code ec;
  for (const char* sub : {"jobs", "images", "probes"}) {
    fs::create_directories(dir_ / sub, ec);
    if (ec) throw Error((dir_ / sub).string(), "", "cannot create directory: " + ec.message());
  }
  if (!options_.shard.whole()) fs::create_directories(dir_ / "shards", ec);
  // Temporary files of an interrupted (killed) run: never results. Removed when the process
  // that wrote them is gone; a live one (another run in the same folder) keeps its own. A shard
  // leaves them alone: the folder may be shared with shards on other hosts, whose pids mean
  // nothing here; the merge, which runs after every shard, removes them.
  std::vector<fs::path> stale;
  if (options_.shard.whole() && !options_.merge_only) SweepDeadTemporaries(&stale);
  const fs::path log_path = options_.shard.whole()
                                ? dir_ / "study.log"
                                : dir_ / "shards" / (options_.shard.Name() + ".log");
  log_ = std::make_unique<Log>(log_path.string(), options_.progress_bar, options_.quiet);
  if (options_.shard.whole()) {  // A shard's spec holds only its own materials.
    json study = spec_.ToJson();
    study["shadefit_version"] = ShadefitVersion();
    WriteFileAtomic((dir_ / "study.json").string(), study.dump(2) + "\n");
  }
  for (const ReferenceGroup& g : spec_.groups) {
    for (const ReferenceSpec& r : g.references) {
      InputHashes h;
      h.image = Sha256File(r.image_path);
      if (!r.sidecar_path.empty()) h.sidecar = Sha256File(r.sidecar_path);
      h.scene_path = SceneOfSidecar(r.sidecar_path);
      if (!h.scene_path.empty() && fs::exists(h.scene_path)) h.scene = Sha256File(h.scene_path);
      hashes_[r.image_path] = h;
    }
  }
}

void StudyRun::BuildJobs() {
  const std::string version = ShadefitVersion();
  for (std::size_t gi = 0; gi < spec_.groups.size(); ++gi) {
    const ReferenceGroup& g = spec_.groups[gi];
    json refs = json::array();
    for (const ReferenceSpec& r : g.references) {
      const InputHashes& h = hashes_.at(r.image_path);
      refs.push_back({{"name", r.name}, {"lighting", r.lighting}, {"image", h.image},
                      {"sidecar", h.sidecar}, {"scene", h.scene}});
    }
    std::vector<int> fit_jobs;
    std::vector<std::string> fit_hashes;
    for (const auto& train : spec_.training_sets) {
      for (const std::string& model : spec_.models) {
        Job job;
        job.kind = Job::Kind::kFit;
        job.group = static_cast<int>(gi);
        job.model = model;
        job.train = train;
        job.label = spec_.Label(model, train);
        job.id = FileSafe(fmt::format("fit.{}.{}.{}", g.material, model, JoinTrain(train)));
        const FitSettings& s = spec_.model_settings.at(model);
        json context = {{"kind", "fit"},
                        {"model", model},
                        {"label", job.label},
                        {"train", train},
                        {"test_lightings", spec_.test_lightings},
                        {"settings", s.ToJson()},
                        {"metrics", {{"exposure_stops", spec_.metrics_exposure_stops},
                                     {"ppd", spec_.metrics_ppd}}},
                        {"previews", spec_.previews},
                        {"references", refs}};
        job.hash = Sha256String(version + "\n" + context.dump());
        job.weight = FitJobCost(s, train.size(), g.references.size());
        fit_jobs.push_back(static_cast<int>(jobs_.size()));
        fit_hashes.push_back(job.hash);
        jobs_.push_back(job);
      }
    }
    if (!spec_.probes.empty()) {
      Job job;
      job.kind = Job::Kind::kProbe;
      job.group = static_cast<int>(gi);
      job.id = FileSafe("probe." + g.material);
      job.deps = fit_jobs;
      json context = {{"kind", "probe"}, {"probes", spec_.probes}, {"references", refs},
                      {"fits", fit_hashes}};
      job.hash = Sha256String(version + "\n" + context.dump());
      job.weight = ProbeJobCost(spec_.probes.size());
      jobs_.push_back(job);
    }
  }
}

bool StudyRun::UpToDate(const Job& job) const {
  if (options_.force) return false;
  std::ifstream in(JobPath(job));
  if (!in) return false;
  try {
    const json j = json::parse(in);
    if (j.value("hash", "") != job.hash) return false;
    if (j.value("status", "") == kStatusGlLost) return false;  // Retried by every run.
    for (const auto& out : j.value("outputs", json::array())) {
      if (!fs::exists(dir_ / out.get<std::string>())) return false;
    }
    return true;
  } catch (const json::exception&) {
    return false;
  }
}

double StudyRun::ErrorScale(const fit::FitReference& ref) const {
  // A quarter of the reference's 99th-percentile radiance (mean RGB over covered, lit pixels):
  // one scale per reference, shared by every model's error map so they compare by eye. Only lit
  // pixels count: under a rim light most of the sphere is black, and a percentile over all of it
  // gave a range near 0 that saturated every map.
  std::vector<float> v;
  const Image& im = ref.image;
  for (int y = 0; y < im.height; ++y) {
    for (int x = 0; x < im.width; ++x) {
      if (im.channels >= 4 && im.at(x, y, 3) < 0.5f) continue;
      const float mean = (im.at(x, y, 0) + im.at(x, y, 1) + im.at(x, y, 2)) / 3.0f;
      if (mean > 0) v.push_back(mean);
    }
  }
  if (v.empty()) return 1.0;
  const std::size_t k = static_cast<std::size_t>(0.99 * (v.size() - 1));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return std::max(1e-6, 0.25 * v[k]);
}

Image CoverageMask(const Image& image) {
  Image mask(image.width, image.height, 1, 1.0f);
  if (image.channels < 4) return mask;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) mask.at(x, y, 0) = image.at(x, y, 3) > 0.5f ? 1.f : 0.f;
  }
  return mask;
}

json MetricsSummary(const metrics::MetricsReport& m) {
  const auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  return {{"rmse", num(m.rmse)},
          {"relative_rmse", num(m.relative_rmse)},
          {"log_rmse", num(m.log_rmse)},
          {"mae", num(m.mae)},
          {"psnr", num(m.psnr)},
          {"ssim", num(m.ssim_rgb.mean)},
          {"ms_ssim", num(m.ms_ssim.value)},
          {"ciede2000_mean", num(m.ciede2000.mean)},
          {"flip_ldr_mean", num(m.flip_ldr.mean)},
          {"flip_hdr_mean", num(m.flip_hdr.mean)}};
}

void StudyRun::RunFitJob(Job& job, Worker& worker) {
  const ReferenceGroup& g = spec_.groups[job.group];
  const FitSettings& s = spec_.model_settings.at(job.model);
  const auto t0 = Clock::now();

  std::vector<fit::FitReference> refs;
  for (const ReferenceSpec& r : g.references) refs.push_back(fit::LoadReference(r.image_path));

  fit::FitProblem problem;
  problem.model = job.model;
  problem.fixed = s.fixed;
  for (std::size_t i = 0; i < refs.size(); ++i) {
    const std::string& lighting = g.references[i].lighting;
    if (std::find(job.train.begin(), job.train.end(), lighting) == job.train.end()) continue;
    fit::FitReference ref = refs[i];
    if (s.pixel_stride > 1) {
      // Subsample by mask: every stride-th pixel in x and y, keeping any mask it had.
      Image mask(ref.image.width, ref.image.height, 1, 0.0f);
      for (int y = 0; y < mask.height; y += s.pixel_stride) {
        for (int x = 0; x < mask.width; x += s.pixel_stride) {
          mask.at(x, y, 0) = ref.mask.empty() || ref.mask.at(x, y, 0) > 0.5f ? 1.f : 0.f;
        }
      }
      ref.mask = std::move(mask);
    }
    problem.references.push_back(std::move(ref));
  }
  fit::FitOptions fo;
  fo.loss = fit::ParseLoss(s.loss);
  fo.loss_scale = s.loss_scale;
  fo.starts = s.starts;
  fo.seed = s.seed;
  fo.exposure = fit::ParseExposure(s.exposure);
  fo.path = fit::ParsePath(s.path);
  fo.max_iterations = s.max_iterations;
  fo.environment_samples = s.environment_samples;
  // One Ceres thread per fit: a fit's sums then run in one fixed order, so its numbers are the
  // same bytes for any -j, any shard count and any machine load (the runner parallelises over
  // jobs instead; docs/studies.md, "Determinism").
  fo.num_threads = kCeresThreadsPerFit;
  fo.render_outputs = false;  // The evaluation below renders every lighting, training ones too.
  fo.renderer = worker.renderer.get();
  if (FaultArmed("gl-lost")) throw GlContextLostError("", "GL", "context lost (simulated)");
  fit::FitResult result;
  try {
    result = fit::Fit(problem, fo);
  } catch (const fit::DegenerateReferenceError& e) {
    WriteFailedFit(job, kStatusDegenerate, e.what());
    return;
  }
  KillPoint("fit");
  if (FaultArmed("nan-residuals")) {
    result.final_cost = std::numeric_limits<double>::quiet_NaN();
    for (double& v : result.values) v = std::numeric_limits<double>::quiet_NaN();
  }
  if (!std::isfinite(result.final_cost)) {
    WriteFailedFit(job, kStatusNan,
                   fmt::format("the solve ended with a non-finite cost ({})", result.termination));
    return;
  }
  const char* status = result.converged ? kStatusOk : kStatusNotConverged;
  if (!result.converged) {
    log_->Line(fmt::format("{}: fit did not converge ({}); recorded as such", job.id,
                           result.termination));
  }

  json evaluations = json::array();
  json outputs = json::array();
  metrics::MetricsParameters mp;
  mp.exposure_stops = spec_.metrics_exposure_stops;
  mp.ppd = spec_.metrics_ppd;
  for (std::size_t i = 0; i < refs.size(); ++i) {
    const ReferenceSpec& rs = g.references[i];
    const fit::FitReference& ref = refs[i];
    Image prediction;
    const double rmse = fit::EvaluateModelOnReference(ref, job.model, result.values,
                                                      result.exposure, worker.renderer.get(),
                                                      &prediction);
    const Image mask = CoverageMask(ref.image);
    mp.names = {rs.image_path, job.label + " fit", ""};
    metrics::MetricsMaps maps;
    metrics::MetricsReport m;
    bool masked = true;
    try {
      m = metrics::ComputeMetrics(ref.image.Channels(0, 3), prediction.Channels(0, 3), &mask, mp,
                                  &maps);
    } catch (const Error& e) {
      // MS-SSIM's coarsest scale can leave no window inside a small object's mask; then every
      // metric of this reference is taken over the whole frame (background is 0 in both) and
      // the evaluation says so. The mask is the reference's, so all fits of it are alike.
      if (std::string(e.what()).find("SSIM window") == std::string::npos) throw;
      masked = false;
      m = metrics::ComputeMetrics(ref.image.Channels(0, 3), prediction.Channels(0, 3), nullptr, mp,
                                  &maps);
    }
    const bool train = std::find(job.train.begin(), job.train.end(), rs.lighting) != job.train.end();
    json e = {{"reference", rs.name},
              {"lighting", rs.lighting},
              {"split", train ? "train" : (spec_.IsTest(rs.lighting, job.train) ? "test" : "other")},
              {"rmse_fitter", rmse},
              {"metrics_masked", masked},
              {"metrics", MetricsSummary(m)},
              {"metrics_full", metrics::MetricsToJson(m)}};
    if (spec_.previews) {
      const std::string ref_png = fmt::format("images/{}.reference.png", rs.name);
      const std::string fit_png = fmt::format("images/{}.{}.png", rs.name, FileSafe(job.label));
      const std::string err_png = fmt::format("images/{}.{}.error.png", rs.name, FileSafe(job.label));
      WritePngPreview((dir_ / ref_png).string(), ref.image, spec_.metrics_exposure_stops);
      WritePngPreview((dir_ / fit_png).string(), prediction, spec_.metrics_exposure_stops);
      metrics::FalseColorParameters fc;
      fc.min = 0.0;
      fc.max = ErrorScale(ref);
      metrics::WriteFalseColorPng((dir_ / err_png).string(), maps.absolute_error, fc);
      e["images"] = {{"reference", ref_png}, {"fit", fit_png}, {"error", err_png},
                     {"error_scale", fc.max}};
      outputs.push_back(ref_png);
      outputs.push_back(fit_png);
      outputs.push_back(err_png);
    }
    evaluations.push_back(e);
  }

  json params = json::array();
  const auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  for (const fit::ParameterEstimate& p : result.parameters) {
    params.push_back({{"name", p.name}, {"value", num(p.value)}, {"std_error", num(p.std_error)},
                      {"fixed", p.fixed}, {"undetermined", p.undetermined},
                      {"at_bound", p.at_bound}});
  }
  json j = FitJobHeader(job, status);
  j.update({{"settings", s.ToJson()},
            {"converged", result.converged},
            {"termination", result.termination},
            {"values", result.values},
            {"exposure", result.exposure},
            {"parameters", params},
            {"fit", fit::FitResultToJson(result)},
            {"evaluations", evaluations},
            {"outputs", outputs}});
  // Wall-clock times are not results: they go to the job's timing file, so that the job JSON
  // is the same bytes on every run.
  j["fit"]["solver"].erase("seconds");
  WriteTiming(job, std::chrono::duration<double>(Clock::now() - t0).count(), result.seconds);
  WriteJobJson(JobPath(job), j.dump(1) + "\n");
}

// The fields every fit job JSON starts with, whatever its outcome.
json StudyRun::FitJobHeader(const Job& job, const std::string& status) const {
  return {{"schema", "shadefit.study.job/1"},
          {"id", job.id},
          {"kind", "fit"},
          {"hash", job.hash},
          {"shadefit_version", ShadefitVersion()},
          {"material", spec_.groups[job.group].material},
          {"model", job.model},
          {"label", job.label},
          {"train", job.train},
          {"status", status}};
}

// A fit that left no parameters: recorded with its status and message, no evaluations; the
// material's probes go on without it and results.csv gives it a row per reference with empty
// metrics.
void StudyRun::WriteFailedFit(const Job& job, const std::string& status,
                              const std::string& error) {
  log_->Say(fmt::format("{}: {}: {}; recorded, the study goes on", job.id, status, error));
  json j = FitJobHeader(job, status);
  j.update({{"error", error},
            {"converged", false},
            {"parameters", json::array()},
            {"evaluations", json::array()},
            {"outputs", json::array()}});
  WriteTiming(job, 0.0, -1.0);
  WriteJobJson(JobPath(job), j.dump(1) + "\n");
}

void StudyRun::RunProbeJob(Job& job, Worker& worker) {
  const ReferenceGroup& g = spec_.groups[job.group];
  const auto t0 = Clock::now();
  probes::ProbeInputs in;
  in.renderer = worker.renderer.get();
  for (const ReferenceSpec& r : g.references) {
    fit::FitReference ref = fit::LoadReference(r.image_path);
    probes::ProbeReference pr;
    pr.name = r.name;
    pr.lighting = r.lighting;
    pr.gbuffer = worker.renderer->RenderGBuffer(ref.scene);
    pr.image = std::move(ref.image);
    pr.scene = std::move(ref.scene);
    in.references.push_back(std::move(pr));
  }
  std::vector<std::string> without_fit;
  for (int d : job.deps) {
    std::ifstream f(JobPath(jobs_[d]));
    const json fj = json::parse(f);
    if (!HasFit(fj.value("status", kStatusOk))) {
      without_fit.push_back(fj.value("label", jobs_[d].label));
      continue;
    }
    probes::ModelUnderTest m;
    m.label = fj["label"];
    m.model = fj["model"];
    m.params = fj["values"].get<std::vector<double>>();
    m.exposure = fj["exposure"];
    // The probes name training references by reference name, the study by lighting.
    for (const std::string& lighting : fj["train"].get<std::vector<std::string>>()) {
      for (const ReferenceSpec& r : g.references) {
        if (r.lighting == lighting) m.trained_on.push_back(r.name);
      }
    }
    in.models.push_back(std::move(m));
  }
  if (const auto truth = TruthOfSidecar(g.references.front().sidecar_path)) {
    probes::ModelUnderTest t;
    t.label = "truth";
    t.model = truth->first;
    t.params = truth->second;
    in.truth = t;
  }
  const fs::path probe_dir = dir_ / "probes" / g.material;
  fs::create_directories(probe_dir);
  json results = json::object();
  json outputs = json::array();
  // Every fit of the material failed (a black reference, say): nothing to probe.
  const std::vector<std::string> probe_names =
      in.models.empty() ? std::vector<std::string>{} : spec_.probes;
  for (const std::string& name : probe_names) {
    probes::ProbeResult r;
    if (name == "fresnel") r = probes::FresnelProbe(in);
    else if (name == "highlight") r = probes::HighlightProbe(in);
    else if (name == "energy") r = probes::EnergyProbe(in);
    else r = probes::PortabilityProbe(in);
    probes::WriteProbeOutputs(r, probe_dir.string());
    results[name] = probes::ProbeResultToJson(r);
    for (const char* ext : {".json", ".png"}) {
      const fs::path p = probe_dir / (r.probe + ext);
      if (fs::exists(p)) outputs.push_back(fs::relative(p, dir_).string());
    }
  }
  json j = {{"schema", "shadefit.study.job/1"},
            {"id", job.id},
            {"kind", "probe"},
            {"hash", job.hash},
            {"shadefit_version", ShadefitVersion()},
            {"material", g.material},
            {"status", in.models.empty() ? "no-fit" : "ok"},
            {"fits_without_parameters", without_fit},
            {"probes", results},
            {"outputs", outputs}};
  WriteTiming(job, std::chrono::duration<double>(Clock::now() - t0).count(), -1.0);
  WriteJobJson(JobPath(job), j.dump(1) + "\n");
}

void StudyRun::WorkerLoop(int index) {
  Worker worker;
  try {
    worker.context = std::make_unique<GlContext>();
    worker.context->MakeCurrent();
    worker.renderer = std::make_unique<Renderer>(*worker.context);
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
    // Pick the first pending job whose dependencies are done; probe jobs first (they unblock
    // nothing but finish a material's results).
    Job* next = nullptr;
    bool waiting = false;  // Some pending job waits on a running one.
    const bool stop = options_.interrupt != nullptr && options_.interrupt->load();
    if (!stop) {
      for (int pass = 0; pass < 2 && next == nullptr; ++pass) {
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
          if (ready) {
            next = &job;
            break;
          }
          waiting = true;
        }
      }
    }
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
    const std::string id = next->id;
    double done_w = 0, total_w = 0;
    int done = 0;
    for (const Job& j : jobs_) {
      total_w += j.weight;
      if (j.state == Job::State::kDone || j.state == Job::State::kFailed) {
        done_w += j.weight;
        ++done;
      }
    }
    const double elapsed = std::chrono::duration<double>(Clock::now() - start_).count();
    lock.unlock();
    log_->Line(fmt::format("start {} (worker {})", id, index));
    log_->Progress(done_w, total_w, done, static_cast<int>(jobs_.size()), id, elapsed);
    const auto t0 = Clock::now();
    std::string error;
    // A lost GL context: a new context and renderer, and the job once more; lost again, the
    // fit is recorded as such (and retried by the next run) and the study goes on.
    for (int attempt = 0; attempt < 2; ++attempt) {
      try {
        if (next->kind == Job::Kind::kFit) RunFitJob(*next, worker);
        else RunProbeJob(*next, worker);
        worker.context->CheckNotLost();  // Whatever it rendered after a reset is void.
        error.clear();
        break;
      } catch (const GlContextLostError& e) {
        error = e.what();
        log_->Say(fmt::format("{}: {} (attempt {}); new GL context", id, error, attempt + 1));
        try {
          worker.renderer.reset();
          worker.context = std::make_unique<GlContext>();
          worker.context->MakeCurrent();
          worker.renderer = std::make_unique<Renderer>(*worker.context);
        } catch (const std::exception& again) {
          error = std::string("no new GL context after a loss: ") + again.what();
          break;
        }
        if (attempt == 1 && next->kind == Job::Kind::kFit) {
          try {
            WriteFailedFit(*next, kStatusGlLost, error);
            error.clear();
          } catch (const std::exception& w) {
            error = w.what();
          }
        }
      } catch (const std::exception& e) {
        error = e.what();
        break;
      }
    }
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    lock.lock();
    --running_;
    next->state = error.empty() ? Job::State::kDone : Job::State::kFailed;
    int finished = 0;
    done_w = 0;
    for (const Job& j : jobs_) {
      if (j.state == Job::State::kDone || j.state == Job::State::kFailed) {
        done_w += j.weight;
        ++finished;
      }
    }
    const double el = std::chrono::duration<double>(Clock::now() - start_).count();
    lock.unlock();
    if (error.empty()) {
      log_->Line(fmt::format("done {} in {:.1f} s", id, seconds));
      if (!options_.progress_bar && !options_.quiet) {
        std::fprintf(stderr, "[%d/%zu] done %s (%.1f s)\n", finished, jobs_.size(), id.c_str(),
                     seconds);
      }
    } else {
      log_->Say(fmt::format("FAILED {}: {}", id, error));
    }
    log_->Progress(done_w, total_w, finished, static_cast<int>(jobs_.size()), "", el);
    lock.lock();
    cv_.notify_all();
  }
}

void StudyRun::WriteResultsCsv() {
  std::ostringstream csv;
  const std::vector<std::string> metric_cols = {"rmse", "relative_rmse", "log_rmse", "mae",
                                                "psnr", "ssim", "ms_ssim", "ciede2000_mean",
                                                "flip_ldr_mean", "flip_hdr_mean"};
  csv << "material,lighting,reference,label,model,train,split,converged,status";
  for (const auto& c : metric_cols) csv << "," << c;
  csv << "\n";
  for (const Job& job : jobs_) {
    if (job.kind != Job::Kind::kFit) continue;
    std::ifstream in(JobPath(job));
    const json j = json::parse(in);
    const std::string status = j.value("status", kStatusOk);
    const auto row_start = [&](const std::string& lighting, const std::string& reference,
                               const std::string& split) {
      csv << j["material"].get<std::string>() << "," << lighting << "," << reference << ","
          << j["label"].get<std::string>() << "," << j["model"].get<std::string>() << ","
          << JoinTrain(j["train"]) << "," << split << "," << (j["converged"].get<bool>() ? 1 : 0)
          << "," << status;
    };
    if (!HasFit(status)) {  // No parameters: one row per reference, metrics empty.
      for (const ReferenceSpec& r : spec_.groups[job.group].references) {
        const bool train =
            std::find(job.train.begin(), job.train.end(), r.lighting) != job.train.end();
        row_start(r.lighting, r.name,
                  train ? "train" : (spec_.IsTest(r.lighting, job.train) ? "test" : "other"));
        csv << std::string(metric_cols.size(), ',') << "\n";
      }
      continue;
    }
    for (const json& e : j["evaluations"]) {
      row_start(e["lighting"].get<std::string>(), e["reference"].get<std::string>(),
                e["split"].get<std::string>());
      for (const auto& c : metric_cols) {
        const json& v = e["metrics"][c];
        csv << "," << (v.is_null() ? std::string("") : fmt::format("{:.9g}", v.get<double>()));
      }
      csv << "\n";
    }
  }
  WriteFileAtomic((dir_ / "results.csv").string(), csv.str());
}

void StudyRun::WriteProvenance(const std::string& gl_renderer) {
  json inputs = json::array();
  for (const ReferenceGroup& g : spec_.groups) {
    for (const ReferenceSpec& r : g.references) {
      const InputHashes& h = hashes_.at(r.image_path);
      inputs.push_back({{"reference", r.name},
                        {"image", {{"path", r.image_path}, {"sha256", h.image}}},
                        {"sidecar", {{"path", r.sidecar_path}, {"sha256", h.sidecar}}},
                        {"scene", {{"path", h.scene_path}, {"sha256", h.scene}}}});
    }
  }
  struct utsname u {};
  uname(&u);
  const std::string version = ShadefitVersion();
  const auto plus = version.find('+');
  json jobs = json::array();
  for (const Job& job : jobs_) jobs.push_back({{"id", job.id}, {"hash", job.hash}});
  json p = {
      {"schema", "shadefit.study.provenance/1"},
      {"study", {{"name", spec_.name}, {"path", spec_.path},
                 {"sha256", Sha256String(spec_.text)}, {"text", spec_.text},
                 {"quick", spec_.quick}}},
      {"shadefit", {{"version", version},
                    {"git_revision", plus == std::string::npos ? "unknown" : version.substr(plus + 1)}}},
      {"options", spec_.ToJson()},
      {"inputs", inputs},
      {"jobs", jobs},
      {"dependencies", {{"ceres", CERES_VERSION_STRING},
                        {"opencv", CV_VERSION},
                        {"openimageio", OIIO_VERSION_STRING},
                        {"nlohmann_json", fmt::format("{}.{}.{}", NLOHMANN_JSON_VERSION_MAJOR,
                                                      NLOHMANN_JSON_VERSION_MINOR,
                                                      NLOHMANN_JSON_VERSION_PATCH)},
                        {"fmt", FMT_VERSION}}},
      {"gl_renderer", gl_renderer},
      {"machine", {{"uname", fmt::format("{} {} {} {}", u.sysname, u.release, u.version, u.machine)},
                   {"cpu_count", std::thread::hardware_concurrency()}}},
      {"run", {{"workers", options_.jobs}, {"ceres_threads_per_fit", kCeresThreadsPerFit}}}};
  if (options_.merge_only) {
    json shards = json::array();
    for (const json& m : options_.shard_manifests) {
      shards.push_back({{"shard", m.value("shard", 0)}, {"count", m.value("count", 0)},
                        {"host", m.value("host", "")}, {"gl_renderer", m.value("gl_renderer", "")},
                        {"workers", m.value("workers", 0)}, {"seconds", m.value("seconds", 0.0)},
                        {"materials", m.value("materials", json::array())}});
    }
    p["run"]["merged_shards"] = shards;
  }
  WriteFileAtomic((dir_ / "provenance.json").string(), p.dump(2) + "\n");
}

std::string StudyRun::HostName() const {
  char host[256] = {};
  if (gethostname(host, sizeof host - 1) != 0) return "unknown";
  return host;
}

void StudyRun::WriteTiming(const Job& job, double seconds, double solver_seconds) {
  json t = {{"schema", "shadefit.study.timing/1"},
            {"id", job.id},
            {"seconds", seconds},
            {"host", HostName()},
            {"shard", options_.shard.Name()}};
  if (solver_seconds >= 0) t["solver_seconds"] = solver_seconds;  // Fits only.
  WriteFileAtomic(TimingPath(job), t.dump(1) + "\n");
}

// timings.csv: where the time went, per job (wall seconds, the fit's solver seconds, host and
// shard). Kept out of results.csv, which holds results only and is the same bytes on every run.
void StudyRun::WriteTimingsCsv() {
  std::ostringstream csv;
  csv << "id,kind,material,label,seconds,solver_seconds,host,shard\n";
  for (const Job& job : jobs_) {
    json t = json::object();
    std::ifstream in(TimingPath(job));
    if (in) {
      try {
        t = json::parse(in);
      } catch (const json::exception&) {
        t = json::object();  // A timing is a diagnostic; a bad one leaves its cells empty.
      }
    }
    const auto number = [&](const char* key) {
      return t.contains(key) && t[key].is_number() ? fmt::format("{:.3f}", t[key].get<double>())
                                                   : std::string();
    };
    const auto text = [&](const char* key) {
      return t.contains(key) && t[key].is_string() ? t[key].get<std::string>() : std::string();
    };
    csv << job.id << "," << (job.kind == Job::Kind::kFit ? "fit" : "probe") << ","
        << spec_.groups[job.group].material << "," << job.label << "," << number("seconds") << ","
        << number("solver_seconds") << "," << text("host") << "," << text("shard") << "\n";
  }
  WriteFileAtomic((dir_ / "timings.csv").string(), csv.str());
}

// shards/<i>-of-<N>.json, written last by a shard whose every job is done: what the merge needs
// to reload the study, and the shard's provenance.
void StudyRun::WriteShardManifest(double seconds) {
  json jobs = json::array();
  std::set<std::string> materials;
  for (const Job& job : jobs_) {
    jobs.push_back({{"id", job.id}, {"hash", job.hash}});
    materials.insert(spec_.groups[job.group].material);
  }
  const json m = {{"schema", "shadefit.study.shard/1"},
                  {"shard", options_.shard.index},
                  {"count", options_.shard.count},
                  {"study_path", spec_.path},
                  {"study_sha256", Sha256String(spec_.text)},
                  {"quick", spec_.quick},
                  {"shadefit_version", ShadefitVersion()},
                  {"materials", materials},
                  {"jobs", jobs},
                  {"gl_renderer", gl_renderer_},
                  {"host", HostName()},
                  {"workers", options_.jobs},
                  {"seconds", seconds}};
  WriteFileAtomic((dir_ / "shards" / (options_.shard.Name() + ".json")).string(),
                  m.dump(1) + "\n");
}

// A merge runs nothing: every job of the whole graph must be done with its current hash.
void StudyRun::CheckMergeable() const {
  std::vector<const Job*> missing;
  for (const Job& job : jobs_) {
    if (job.state != Job::State::kSkipped) missing.push_back(&job);
  }
  if (missing.empty()) return;
  const Job& first = *missing.front();
  throw Error(JobPath(first), "", fmt::format("{} of {} job(s) not done or out of date (first: "
                                              "{}); rerun the shard of material '{}'",
                                              missing.size(), jobs_.size(), first.id,
                                              spec_.groups[first.group].material));
}

RunSummary StudyRun::Run() {
  start_ = Clock::now();
  Prepare();
  BuildJobs();
  RunSummary summary;
  summary.study_dir = dir_.string();
  summary.total = static_cast<int>(jobs_.size());
  for (Job& job : jobs_) {
    // A job whose inputs were just (re)made runs again: a fit rerun after a lost GL context
    // gives its probes new parameters under the same hash. Dependencies come first in jobs_.
    const bool deps_unchanged = std::all_of(job.deps.begin(), job.deps.end(), [&](int d) {
      return jobs_[d].state == Job::State::kSkipped;
    });
    if (deps_unchanged && UpToDate(job)) {
      job.state = Job::State::kSkipped;
      summary.skipped_ids.push_back(job.id);
      log_->Line("skip " + job.id + " (unchanged)");
    }
  }
  if (options_.merge_only) {
    CheckMergeable();
    std::vector<fs::path> stale;
    SweepDeadTemporaries(&stale);  // Every shard has finished: what is left is dead.
  }
  const unsigned cpus = std::max(1u, std::thread::hardware_concurrency());
  int workers = options_.jobs > 0 ? options_.jobs : static_cast<int>(cpus);
  const int pending = static_cast<int>(jobs_.size() - summary.skipped_ids.size());
  workers = std::max(1, std::min(workers, pending));
  options_.jobs = workers;
  const std::string part = options_.merge_only      ? " (merge)"
                           : options_.shard.whole() ? ""
                                                    : " (shard " + options_.shard.Name() + ")";
  log_->Say(fmt::format("study {}{}: {} jobs ({} unchanged), {} worker(s), output {}", spec_.name,
                        part, jobs_.size(), summary.skipped_ids.size(), workers, dir_.string()));
  if (pending > 0) {
    std::vector<std::thread> threads;
    for (int i = 0; i < workers; ++i) threads.emplace_back(&StudyRun::WorkerLoop, this, i);
    for (std::thread& t : threads) t.join();
    log_->EndBar();
  }
  if (!first_error_.empty()) throw Error("", "GL", first_error_);
  for (const Job& job : jobs_) {
    switch (job.state) {
      case Job::State::kDone: summary.ran_ids.push_back(job.id); break;
      case Job::State::kFailed: summary.failed_ids.push_back(job.id); break;
      case Job::State::kSkipped: break;
      default: ++summary.not_run; break;
    }
  }
  summary.ran = static_cast<int>(summary.ran_ids.size());
  summary.skipped = static_cast<int>(summary.skipped_ids.size());
  summary.failed = static_cast<int>(summary.failed_ids.size());
  summary.interrupted = options_.interrupt != nullptr && options_.interrupt->load();
  for (const Job& job : jobs_) {
    if (job.kind != Job::Kind::kFit ||
        (job.state != Job::State::kDone && job.state != Job::State::kSkipped)) {
      continue;
    }
    std::ifstream in(JobPath(job));
    try {
      const std::string status = json::parse(in).value("status", kStatusOk);
      if (!HasFit(status)) summary.fits_without_parameters.push_back(job.id + ": " + status);
    } catch (const json::exception&) {
    }
  }
  const bool complete = summary.failed == 0 && summary.not_run == 0 && !summary.interrupted;
  if (complete && !options_.shard.whole()) {
    WriteShardManifest(std::chrono::duration<double>(Clock::now() - start_).count());
  } else if (complete) {
    WriteResultsCsv();
    WriteTimingsCsv();
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
    WriteProvenance(gl);
  }
  summary.seconds = std::chrono::duration<double>(Clock::now() - start_).count();
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
