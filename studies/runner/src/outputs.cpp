#include "outputs.h"

#include <fmt/core.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <set>
#include <sstream>
#include <thread>

#include <ceres/version.h>
#include <OpenImageIO/oiioversion.h>
#include <nlohmann/json.hpp>
#include <opencv2/core/version.hpp>

#include "fit_status.h"
#include "job_kinds.h"
#include "job_records.h"
#include "metric_columns.h"
#include "shadefit/base/files.h"

namespace shadefit::studies::internal {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// Each metric over the pixels "metrics" covers (a measured reference's covered AND measured
// pixels; every covered pixel otherwise), then measured_fraction, then the same metrics over every
// covered pixel as <metric>_all ("metrics_all"; equal to the first for references without a
// measured domain). docs/measured_and_imported.md, "The measured domain".
// kMetricColumns: metric_columns.h.

// A text field of a CSV row as RFC 4180 writes it: in double quotes, inner quotes doubled, when it
// holds a comma, a quote or a line break (a material named by its user may); as it is otherwise,
// so that the files of ordinary names are unchanged.
std::string Text(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string Cell(const json& v) {
  return v.is_number() ? fmt::format("{:.9g}", v.get<double>()) : std::string();
}

std::string HostName() {
  char host[256] = {};
  if (gethostname(host, sizeof host - 1) != 0) return "unknown";
  return host;
}

// One fit job's rows of results.csv.
void AppendResultRows(const RunContext& context, const Job& job, std::ostringstream& csv) {
  const FitJobRecord fit = ReadFitJobRecord(context.paths.JobJson(job));
  const std::string& object = context.spec.groups[job.group].object;
  const auto row_start = [&](const std::string& lighting, const std::string& reference,
                             const std::string& split) {
    csv << Text(fit.material) << "," << Text(lighting) << "," << Text(reference) << ","
        << Text(fit.label) << "," << fit.model << "," << Text(JoinTrain(fit.train)) << ","
        << fit::LossName(job.loss) << "," << split << "," << (fit.converged ? 1 : 0) << ","
        << FitStatusName(fit.status);
  };
  if (!HasFit(fit.status)) {  // No parameters: one row per reference, no metrics.
    for (const ReferenceSpec& r : context.spec.groups[job.group].references) {
      row_start(r.lighting, r.name, SplitOf(context.spec, r.lighting, job.train));
      // kMetricColumns, measured_fraction, the _all columns, the regions: all empty.
      csv << std::string(2 * kMetricColumns.size() + 1 + kRegionColumns.size() *
                                                              kRegionNames.size(), ',')
          << "," << Text(object) << "\n";
    }
    return;
  }
  for (const EvaluationRecord& e : fit.evaluations) {
    row_start(e.lighting, e.reference, e.split);
    for (const auto& c : kMetricColumns) csv << "," << Cell(e.metrics.value(c, json()));
    csv << "," << Cell(json(e.measured_fraction));
    for (const auto& c : kMetricColumns) csv << "," << Cell(e.metrics_all.value(c, json()));
    const json regions = e.details.value("regions", json());
    for (const auto& r : kRegionNames) {
      for (const auto& c : kRegionColumns) {
        csv << "," << (regions.is_object() ? Cell(regions[r][c]) : std::string());
      }
    }
    csv << "," << Text(object) << "\n";
  }
}

json ProvenanceInputs(const StudySpec& spec, const std::map<std::string, InputHashes>& hashes) {
  json inputs = json::array();
  for (const ReferenceGroup& g : spec.groups) {
    for (const ReferenceSpec& r : g.references) {
      const InputHashes& h = hashes.at(r.image_path);
      inputs.push_back({{"reference", r.name},
                        {"image", {{"path", r.image_path}, {"sha256", h.image}}},
                        {"sidecar", {{"path", r.sidecar_path}, {"sha256", h.sidecar}}},
                        {"scene", {{"path", h.scene_path}, {"sha256", h.scene}}}});
    }
  }
  return inputs;
}

json JobHashes(const std::vector<Job>& jobs) {
  json out = json::array();
  for (const Job& job : jobs) out.push_back({{"id", job.id}, {"hash", job.hash}});
  return out;
}

json DependencyVersions() {
  return {{"ceres", CERES_VERSION_STRING},
          {"opencv", CV_VERSION},
          {"openimageio", OIIO_VERSION_STRING},
          {"nlohmann_json", fmt::format("{}.{}.{}", NLOHMANN_JSON_VERSION_MAJOR,
                                        NLOHMANN_JSON_VERSION_MINOR, NLOHMANN_JSON_VERSION_PATCH)},
          {"fmt", FMT_VERSION}};
}

// The merged shards' own records, for a merge's provenance.
json MergedShards(const std::vector<json>& manifests) {
  json shards = json::array();
  for (const json& m : manifests) {
    shards.push_back({{"shard", m.value("shard", 0)}, {"count", m.value("count", 0)},
                      {"host", m.value("host", "")}, {"gl_renderer", m.value("gl_renderer", "")},
                      {"workers", m.value("workers", 0)}, {"seconds", m.value("seconds", 0.0)},
                      {"materials", m.value("materials", json::array())}});
  }
  return shards;
}

}  // namespace

void WriteStudyJson(const RunContext& context) {
  json study = context.spec.ToJson();
  study["shadefit_version"] = ShadefitVersion();
  WriteTextAtomic((context.paths.dir / "study.json").string(), study.dump(2) + "\n");
}

void WriteResultsCsv(const RunContext& context, const std::vector<Job>& jobs) {
  std::ostringstream csv;
  csv << "material,lighting,reference,label,model,train,loss,split,converged,status";
  for (const auto& c : kMetricColumns) csv << "," << c;
  csv << ",measured_fraction";
  for (const auto& c : kMetricColumns) csv << "," << c << "_all";
  for (const auto& r : kRegionNames) {
    for (const auto& c : kRegionColumns) csv << ",region_" << r << "_" << c;
  }
  csv << ",object\n";  // The group's object ("" for spheres and planes): the report's unit.
  for (const Job& job : jobs) {
    if (job.kind == Job::Kind::kFit) AppendResultRows(context, job, csv);
  }
  WriteTextAtomic((context.paths.dir / "results.csv").string(), csv.str());
}

void WriteTiming(const RunContext& context, const Job& job, const StageClock& clock,
                 double solver_seconds) {
  json stages = json::object();
  for (const std::string& s : kStageNames) {
    if (clock.Seconds(s) > 0) stages[s] = clock.Seconds(s);
  }
  json t = {{"schema", "shadefit.study.timing/2"},
            {"id", job.id},
            {"seconds", clock.Total()},
            {"stages", stages},
            {"host", HostName()},
            {"shard", context.options.shard.Name()}};
  if (solver_seconds >= 0) t["solver_seconds"] = solver_seconds;  // Fits only.
  WriteTextAtomic(context.paths.TimingJson(job), t.dump(1) + "\n");
}

// Kept out of results.csv, which holds results only and is the same bytes on every run. Returns
// the totals per stage over the jobs (kStageNames' order), for the closing table.
std::vector<double> WriteTimingsCsv(const RunContext& context, const std::vector<Job>& jobs) {
  std::ostringstream csv;
  csv << "id,kind,material,label,seconds,solver_seconds,host,shard";
  for (const std::string& s : kStageNames) csv << "," << s << "_seconds";
  csv << "\n";
  std::vector<double> totals(kStageNames.size(), 0.0);
  for (const Job& job : jobs) {
    json t = json::object();
    std::ifstream in(context.paths.TimingJson(job));
    if (in) {
      try {
        t = json::parse(in);
      } catch (const json::exception&) {
        t = json::object();  // A timing is a diagnostic; a bad one leaves its cells empty.
      }
    }
    const auto number = [](const json& o, const std::string& key) {
      return o.is_object() && o.contains(key) && o[key].is_number()
                 ? fmt::format("{:.3f}", o[key].get<double>())
                 : std::string();
    };
    const auto text = [&](const char* key) {
      return t.contains(key) && t[key].is_string() ? t[key].get<std::string>() : std::string();
    };
    csv << Text(job.id) << "," << (job.kind == Job::Kind::kFit ? "fit" : "probe") << ","
        << Text(context.spec.groups[job.group].material) << "," << Text(job.label) << ","
        << number(t, "seconds") << "," << number(t, "solver_seconds") << ","
        << Text(text("host")) << "," << text("shard");
    const json stages = t.value("stages", json::object());
    for (std::size_t i = 0; i < kStageNames.size(); ++i) {
      csv << "," << number(stages, kStageNames[i]);
      if (job.state == Job::State::kDone && stages.is_object() &&
          stages.contains(kStageNames[i]) && stages[kStageNames[i]].is_number()) {
        totals[i] += stages[kStageNames[i]].get<double>();
      }
    }
    csv << "\n";
  }
  WriteTextAtomic((context.paths.dir / "timings.csv").string(), csv.str());
  return totals;
}

std::string StageTable(const std::vector<double>& totals) {
  double sum = 0;
  for (double t : totals) sum += t;
  if (sum <= 0) return "";
  std::string out = fmt::format("where the jobs' {:.1f} s went (summed over workers):", sum);
  for (std::size_t i = 0; i < kStageNames.size(); ++i) {
    if (totals[i] <= 0) continue;
    out += fmt::format("\n  {:<16} {:8.1f} s  {:5.1f}%", kStageNames[i], totals[i],
                       100.0 * totals[i] / sum);
  }
  return out;
}

void WriteProvenance(const RunContext& context, const std::vector<Job>& jobs,
                     const std::map<std::string, InputHashes>& hashes,
                     const std::string& gl_renderer) {
  const StudySpec& spec = context.spec;
  struct utsname u {};
  uname(&u);
  const std::string version = ShadefitVersion();
  const auto plus = version.find('+');
  json p = {
      {"schema", "shadefit.study.provenance/1"},
      {"study", {{"name", spec.name}, {"path", spec.path}, {"sha256", Sha256String(spec.text)},
                 {"text", spec.text}, {"quick", spec.quick}}},
      {"shadefit", {{"version", version},
                    {"git_revision",
                     plus == std::string::npos ? "unknown" : version.substr(plus + 1)}}},
      {"options", spec.ToJson()},
      {"inputs", ProvenanceInputs(spec, hashes)},
      {"jobs", JobHashes(jobs)},
      {"dependencies", DependencyVersions()},
      {"gl_renderer", gl_renderer},
      {"machine",
       {{"uname", fmt::format("{} {} {} {}", u.sysname, u.release, u.version, u.machine)},
        {"cpu_count", std::thread::hardware_concurrency()}}},
      {"run",
       {{"workers", context.options.jobs}, {"ceres_threads_per_fit", kCeresThreadsPerFit}}}};
  if (context.options.merge_only) {
    p["run"]["merged_shards"] = MergedShards(context.options.shard_manifests);
  }
  WriteTextAtomic((context.paths.dir / "provenance.json").string(), p.dump(2) + "\n");
}

void WriteShardManifest(const RunContext& context, const std::vector<Job>& jobs,
                        const std::string& gl_renderer, double seconds) {
  std::set<std::string> materials;
  for (const Job& job : jobs) materials.insert(context.spec.groups[job.group].material);
  const RunOptions& o = context.options;
  const json m = {{"schema", "shadefit.study.shard/1"},
                  {"shard", o.shard.index},
                  {"count", o.shard.count},
                  {"study_path", context.spec.path},
                  {"study_sha256", Sha256String(context.spec.text)},
                  {"quick", context.spec.quick},
                  {"shadefit_version", ShadefitVersion()},
                  {"materials", materials},
                  {"jobs", JobHashes(jobs)},
                  {"gl_renderer", gl_renderer},
                  {"host", HostName()},
                  {"workers", o.jobs},
                  {"seconds", seconds}};
  WriteTextAtomic((context.paths.dir / "shards" / (o.shard.Name() + ".json")).string(),
                  m.dump(1) + "\n");
}

}  // namespace shadefit::studies::internal
