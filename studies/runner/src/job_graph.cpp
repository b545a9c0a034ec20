#include "job_graph.h"

#include <fmt/core.h>

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "job_cost.h"
#include "shadefit/base/error.h"
#include "shadefit/base/files.h"
#include "shadefit/probes/probes.h"
#include "shadefit/reference_images/measured_brdf.h"
#include "shadefit/reference_images/sidecar.h"
#include "shadefit/studies/runner.h"

namespace shadefit::studies::internal {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// A fit job's hash context: everything its results depend on besides shadefit's version.
json FitContext(const StudySpec& spec, const FitSettings& settings, const FitSpec& f,
                const json& refs) {
  return {{"kind", "fit"},
          {"model", f.model->name},
          {"label", f.label},
          {"train", f.train},
          {"test_lightings", spec.test_lightings},
          {"settings", settings.ToJson()},
          {"metrics", {{"exposure_stops", spec.metrics_exposure_stops}, {"ppd", spec.metrics_ppd}}},
          {"previews", spec.previews},
          {"references", refs}};
}

// SHA-256 of a measured BRDF's files (reference_images::MeasuredBrdfFiles).
json BrdfHashes(const std::string& brdf) {
  json out = json::array();
  for (const std::string& f : reference_images::MeasuredBrdfFiles(brdf))
    out.push_back(Sha256File(f));
  return out;
}

std::vector<std::string> ProbeNamesOf(const StudySpec& spec) {
  std::vector<std::string> names;
  for (probes::ProbeKind kind : spec.probes) names.emplace_back(probes::ProbeName(kind));
  return names;
}

}  // namespace

std::map<std::string, InputHashes> HashInputs(const StudySpec& spec) {
  std::map<std::string, InputHashes> hashes;
  for (const ReferenceGroup& g : spec.groups) {
    for (const ReferenceSpec& r : g.references) {
      InputHashes h;
      h.image = Sha256File(r.image_path);
      if (!r.sidecar_path.empty()) h.sidecar = Sha256File(r.sidecar_path);
      h.scene_path = reference_images::SceneOfSidecar(r.sidecar_path);
      if (!h.scene_path.empty() && fs::exists(h.scene_path)) h.scene = Sha256File(h.scene_path);
      hashes[r.image_path] = h;
    }
  }
  return hashes;
}

std::vector<Job> BuildJobs(const StudySpec& spec,
                           const std::map<std::string, InputHashes>& hashes) {
  const std::string version = ShadefitVersion();
  std::vector<Job> jobs;
  for (std::size_t gi = 0; gi < spec.groups.size(); ++gi) {
    const ReferenceGroup& g = spec.groups[gi];
    json refs = json::array();
    for (const ReferenceSpec& r : g.references) {
      const InputHashes& h = hashes.at(r.image_path);
      refs.push_back({{"name", r.name},
                      {"lighting", r.lighting},
                      {"image", h.image},
                      {"sidecar", h.sidecar},
                      {"scene", h.scene}});
    }
    std::vector<int> fit_jobs;
    std::vector<std::string> fit_hashes;
    for (const FitSpec& f : spec.Fits()) {
      Job job;
      job.kind = Job::Kind::kFit;
      job.group = static_cast<int>(gi);
      job.model = f.model;
      job.train = f.train;
      job.loss = f.loss;
      job.label = f.label;
      job.id = FitJobId(spec, g.material, f);
      const FitSettings settings = spec.SettingsOf(f.model, f.loss);
      json context = FitContext(spec, settings, f, refs);
      // A BRDF-space fit reads the BRDF file itself, not only the images rendered from it; so
      // does an image fit that starts from one.
      const std::string brdf_path = MeasuredBrdfPath(spec, g.material);
      if (f.role == FitRole::kBrdf || (settings.start == StartFrom::kBrdf && !brdf_path.empty())) {
        context["brdf"] = BrdfHashes(brdf_path);
      }
      job.hash = Sha256String(version + "\n" + context.dump());
      job.weight = FitJobCost(settings, f.train.size(), g.references.size());
      fit_jobs.push_back(static_cast<int>(jobs.size()));
      fit_hashes.push_back(job.hash);
      jobs.push_back(job);
    }
    if (!spec.probes.empty()) {
      Job job;
      job.kind = Job::Kind::kProbe;
      job.group = static_cast<int>(gi);
      job.id = FileSafe("probe." + g.material);
      job.deps = fit_jobs;
      // The result schema too: a probe job written in an older format must run again, even by
      // a build whose version string did not change (a stale configure).
      const json context = {{"kind", "probe"},           {"probes", ProbeNamesOf(spec)},
                            {"plots", spec.probe_plots}, {"schema", probes::kProbeResultSchema},
                            {"references", refs},        {"fits", fit_hashes}};
      job.hash = Sha256String(version + "\n" + context.dump());
      job.weight = ProbeJobCost(spec.probes.size());
      jobs.push_back(job);
    }
  }
  return jobs;
}

std::string FitJobId(const StudySpec& spec, const std::string& material, const FitSpec& f) {
  std::string id =
      FileSafe(fmt::format("fit.{}.{}.{}", material, f.model->name, JoinTrain(f.train)));
  // A study of several losses: one job per loss (the BRDF-space fit: one, unsuffixed).
  if (spec.losses.size() > 1 && f.role != FitRole::kBrdf)
    id += fmt::format(".{}", fit::LossName(f.loss));
  return id;
}

void CheckJobIds(const StudySpec& spec) {
  std::map<std::string, std::pair<std::string, std::string>> seen;  // id -> material, label
  for (const ReferenceGroup& g : spec.groups) {
    for (const FitSpec& f : spec.Fits()) {
      const std::string id = FitJobId(spec, g.material, f);
      const auto [it, inserted] = seen.emplace(id, std::make_pair(g.material, f.label));
      if (inserted) continue;
      const auto& [material, label] = it->second;
      throw Error(
          spec.path, material == g.material ? "fit" : "material",
          material == g.material
              ? fmt::format("fits '{}' and '{}' would both write jobs/{}.json", label, f.label, id)
              : fmt::format("materials '{}' and '{}' would both write jobs/{}.json (file "
                            "names replace '/', '\\' and ' ' by '_'): rename one",
                            material, g.material, id));
    }
  }
}

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

std::string SplitOf(const StudySpec& spec, const std::string& lighting,
                    const std::vector<std::string>& train) {
  if (std::find(train.begin(), train.end(), lighting) != train.end()) return "train";
  return spec.IsTest(lighting, train) ? "test" : "other";
}

std::string StudyPaths::JobJson(const Job& job) const {
  return (dir / "jobs" / (job.id + ".json")).string();
}

std::string StudyPaths::TimingJson(const Job& job) const {
  return (dir / "jobs" / (job.id + ".timing.json")).string();
}

}  // namespace shadefit::studies::internal
