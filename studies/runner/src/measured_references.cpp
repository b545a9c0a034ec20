// [[measured]] sources of a study: every BRDF file of the folder rendered under every scene with
// shadefit's measured renderer (reference_images/, docs/measured_and_imported.md), into
// OUT/<study>/references/<material>-<lighting>.exr with its sidecar, then one reference group
// per material. A reference is re-rendered only when its key changes: the SHA-256 of the BRDF
// file(s), the scene's bytes, the sample count, the shadefit version and the format of the
// outputs (/2: the measured domain, <name>.domain.png, beside the image), or when one of its
// files is missing. The renders are deterministic (per-pixel seeds; the thread count does not
// change them).
#include <fmt/core.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "shadefit/base/error.h"
#include "shadefit/base/files.h"
#include "shadefit/reference_images/measured_brdf.h"
#include "shadefit/reference_images/render_measured.h"
#include "shadefit/render/gl_context.h"
#include "shadefit/render/renderer.h"
#include "progress_log.h"
#include "shadefit/studies/runner.h"

namespace shadefit::studies {
namespace fs = std::filesystem;

namespace {

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "", "cannot read");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string ReferenceKey(const MeasuredSource& src, std::size_t material, std::size_t lighting) {
  std::string key = "shadefit.measured-reference/2\n" + ShadefitVersion() + "\n";
  for (const std::string& f : reference_images::MeasuredBrdfFiles(src.brdfs[material])) {
    key += Sha256File(f) + "\n";
  }
  key += Sha256String(ReadAll(src.scenes[lighting])) + "\n";
  key += fmt::format("samples {}\n", src.samples);
  return Sha256String(key);
}

}  // namespace

MeasuredSummary MaterialiseMeasuredReferences(StudySpec* spec, const std::string& out_dir,
                                              const MeasuredOptions& options) {
  MeasuredSummary summary;
  bool any = false;
  for (const MeasuredSource& src : spec->measured) any = any || !src.brdfs.empty();
  if (!any) return summary;
  const fs::path dir = fs::path(out_dir) / spec->name / "references";
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir)) throw Error(dir.string(), "", "cannot create the folder");
  auto wanted = [&](const MeasuredSource& src, std::size_t m) {
    return options.materials == nullptr || options.materials->count(src.materials[m]) > 0;
  };
  // Each wanted reference's key (it hashes the BRDF files: once per reference), and whether its
  // files are there with that key; the count to render is the progress line's total (the jobs'
  // own, internal::Log: one live line on a terminal, a line per quarter elsewhere).
  std::map<std::string, std::string> key_of;  // By reference name.
  std::set<std::string> up_to_date;
  int to_render = 0;
  for (const MeasuredSource& src : spec->measured) {
    for (std::size_t m = 0; m < src.brdfs.size(); ++m) {
      if (!wanted(src, m)) continue;
      for (std::size_t l = 0; l < src.scenes.size(); ++l) {
        const std::string name = src.materials[m] + "-" + src.lightings[l];
        const std::string image = (dir / (name + ".exr")).string();
        const std::string key = ReferenceKey(src, m, l);
        const fs::path key_path = dir / (name + ".key");
        if (fs::exists(image) && fs::exists(reference_images::SidecarPath(image)) &&
            fs::exists(reference_images::DomainPath(image)) && fs::exists(key_path) &&
            ReadAll(key_path.string()) == key + "\n") {
          up_to_date.insert(name);
        } else {
          ++to_render;
        }
        key_of[name] = key;
      }
    }
  }
  if (!options.render) to_render = 0;
  internal::Log progress("", options.progress_bar, options.quiet || to_render == 0, "references");
  const auto start = std::chrono::steady_clock::now();
  std::unique_ptr<GlContext> context;
  std::unique_ptr<Renderer> renderer;
  for (const MeasuredSource& src : spec->measured) {
    for (std::size_t m = 0; m < src.brdfs.size(); ++m) {
      if (!wanted(src, m)) continue;
      for (const ReferenceGroup& g : spec->groups) {
        if (g.material == src.materials[m]) {
          throw Error(spec->path, "measured.folder",
                      "material '" + g.material + "' is also a [[group]]");
        }
      }
      ReferenceGroup group;
      group.material = src.materials[m];
      group.object = src.object;
      for (std::size_t l = 0; l < src.scenes.size(); ++l) {
        ReferenceSpec ref;
        ref.name = group.material + "-" + src.lightings[l];
        ref.material = group.material;
        ref.lighting = src.lightings[l];
        ref.image_path = (dir / (ref.name + ".exr")).string();
        ref.sidecar_path = reference_images::SidecarPath(ref.image_path);
        const std::string& key = key_of.at(ref.name);
        const fs::path key_path = dir / (ref.name + ".key");
        if (up_to_date.count(ref.name) > 0) {
          ++summary.unchanged;
        } else if (!options.render) {
          throw Error(ref.image_path, "",
                      "measured reference missing or out of date; rerun the "
                      "shard that renders material '" +
                          group.material + "'");
        } else {
          if (!renderer) {
            context = std::make_unique<GlContext>();
            renderer = std::make_unique<Renderer>(*context);
          }
          reference_images::MeasuredReferenceRequest request;
          request.brdf_path = src.brdfs[m];
          request.scene_path = src.scenes[l];
          request.output = ref.image_path;
          request.options.samples = src.samples;
          // The key is written last: a render interrupted before it is redone by the next run.
          fs::remove(key_path, ec);
          const reference_images::RenderMeasuredStats stats =
              reference_images::MakeMeasuredReference(request, *renderer);
          WriteTextAtomic(key_path.string(), key + "\n");
          ++summary.rendered;
          summary.seconds += stats.seconds;
          if (options.verbose && !options.quiet) {
            progress.Say(fmt::format("measured reference {} ({:.2f} s)", ref.name, stats.seconds));
          }
          const double elapsed =
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
          progress.Progress(summary.rendered, to_render, summary.rendered, to_render, 0, ref.name,
                            elapsed);
        }
        group.references.push_back(ref);
      }
      std::sort(
          group.references.begin(), group.references.end(),
          [](const ReferenceSpec& a, const ReferenceSpec& b) { return a.lighting < b.lighting; });
      spec->groups.push_back(std::move(group));
    }
  }
  progress.EndBar();
  return summary;
}

}  // namespace shadefit::studies
