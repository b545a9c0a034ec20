// A probe job: the study's probes on one material's references, its fits and (when the sidecar
// has an exact twin) its true BRDF; for a [[measured]] material also the BRDF-space probe on the
// measured BRDF file itself; then the job JSON, last.
#include <fmt/format.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>

#include <nlohmann/json.hpp>

#include "job_kinds.h"
#include "job_records.h"
#include "stage_clock.h"
#include "outputs.h"
#include "shadefit/probes/probes.h"
#include "shadefit/reference_images/measured_brdf.h"
#include "shadefit/reference_images/reference.h"
#include "test_hooks.h"

namespace shadefit::studies::internal {
namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;

std::vector<probes::ProbeReference> ProbeReferences(const RunContext& context,
                                                    const ReferenceGroup& g, Renderer& renderer) {
  std::vector<std::string> paths;
  for (const ReferenceSpec& r : g.references) paths.push_back(r.image_path);
  const std::vector<std::shared_ptr<const reference_images::Reference>> refs =
      context.References(paths);
  std::vector<probes::ProbeReference> out;
  for (std::size_t i = 0; i < refs.size(); ++i) {
    const ReferenceSpec& r = g.references[i];
    const reference_images::Reference* ref = refs[i].get();
    probes::ProbeReference pr;
    pr.name = r.name;
    pr.lighting = r.lighting;
    pr.gbuffer = renderer.RenderGBuffer(ref->scene);
    pr.image = ref->image;
    pr.scene = ref->scene;
    out.push_back(std::move(pr));
  }
  return out;
}

// The fits the job depends on, from their JSONs; the labels of those that left no parameters go
// to `without_fit`.
std::vector<probes::ModelUnderTest> FittedModels(const RunContext& context, const Job& job,
                                                 const std::vector<Job>& jobs,
                                                 std::vector<std::string>* without_fit) {
  const ReferenceGroup& g = context.spec.groups[job.group];
  std::vector<probes::ModelUnderTest> models;
  for (int d : job.deps) {
    const std::string path = context.paths.JobJson(jobs[d]);
    const FitJobRecord fit = ReadFitJobRecord(path);
    if (!HasFit(fit.status)) {
      without_fit->push_back(fit.label);
      continue;
    }
    // The job's model, resolved when the study was loaded; its record must be that job's.
    if (fit.model != jobs[d].model->name) {
      throw Error(path, "model", fmt::format("'{}', but the job fits {}", fit.model,
                                             jobs[d].model->name));
    }
    probes::ModelUnderTest m;
    m.label = fit.label;
    m.model = jobs[d].model;
    m.params = fit.values;
    m.exposure = fit.exposure;
    // The probes name training references by reference name, the study by lighting.
    for (const std::string& lighting : fit.train) {
      for (const ReferenceSpec& r : g.references) {
        if (r.lighting == lighting) m.trained_on.push_back(r.name);
      }
    }
    models.push_back(std::move(m));
  }
  return models;
}

}  // namespace

void RunProbeJob(const RunContext& context, const Job& job, const std::vector<Job>& jobs,
                 Renderer& renderer) {
  const ReferenceGroup& g = context.spec.groups[job.group];
  StageClock clock;
  probes::ProbeInputs in;
  in.renderer = &renderer;
  probes::ModelRenders renders;  // each fit under each reference, rendered once for all probes
  in.renders = &renders;
  in.references = ProbeReferences(context, g, renderer);
  std::vector<std::string> without_fit;
  in.models = FittedModels(context, job, jobs, &without_fit);
  in.truth = probes::TruthOfReference(g.references.front().sidecar_path);
  clock.Lap("probe_inputs");
  const fs::path probe_dir = context.paths.dir / "probes" / g.material;
  fs::create_directories(probe_dir);
  ProbeJobRecord record;
  record.id = job.id;
  record.hash = job.hash;
  record.shadefit_version = ShadefitVersion();
  record.material = g.material;
  record.status = in.models.empty() ? "no-fit" : "ok";
  record.fits_without_parameters = without_fit;
  // Every fit of the material failed (a black reference, say): nothing to probe.
  const std::vector<probes::ProbeKind> kinds =
      in.models.empty() ? std::vector<probes::ProbeKind>{} : context.spec.probes;
  std::unique_ptr<reference_images::MeasuredBrdf> measured;
  for (const probes::ProbeKind kind : kinds) {
    const std::string stage = std::string("probe_") + probes::ProbeName(kind);
    if (kind == probes::ProbeKind::kBrdf) {
      // Only a measured material has a BRDF to read; a [[group]] of images says so and goes on.
      const std::string path = MeasuredBrdfPath(context.spec, g.material);
      if (path.empty()) {
        record.probes_skipped.push_back(
            {{"probe", "brdf"}, {"why", "not a [[measured]] material"}});
        clock.Lap(stage);
        continue;
      }
      if (!measured) measured = reference_images::LoadMeasuredBrdf(path);
      in.measured_brdf = measured.get();
    }
    const probes::ProbeResult r = probes::RunProbe(kind, in);
    probes::WriteProbeOutputs(r, probe_dir.string(), context.spec.probe_plots);
    record.probes[probes::ProbeName(kind)] = probes::ProbeResultToJson(r);
    for (const char* ext : {".json", ".png"}) {
      const fs::path p = probe_dir / (std::string(probes::ProbeName(r.probe)) + ext);
      if (fs::exists(p)) record.outputs.push_back(fs::relative(p, context.paths.dir).string());
    }
    clock.Lap(stage);
  }
  WriteTiming(context, job, clock, -1.0);
  WriteJobJson(context.paths.JobJson(job), ToJson(record).dump(1) + "\n");
}

}  // namespace shadefit::studies::internal
