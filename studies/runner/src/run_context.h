// What every unit of a run reads: the study, the options, where the files go and the log.
#pragma once

#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "brdf_space_fits.h"
#include "job_graph.h"
#include "loaded_references.h"
#include "progress_log.h"
#include "shadefit/base/made_once.h"
#include "shadefit/metrics/flip.h"
#include "shadefit/studies/runner.h"
#include "shadefit/studies/study.h"

namespace shadefit::studies::internal {

// The pixel regions (region_errors.h) of the run's references, by image path: every fit
// compared with a reference splits its pixels the same way, so the first one finds them (a
// G-buffer render and a partial sort) and the rest take its map.
class ReferenceRegions {
 public:
  // The map kept for `image_path`, else make()'s, kept.
  template <typename Make>
  std::shared_ptr<const std::vector<signed char>> Get(const std::string& image_path, Make make) {
    return maps_.Get(image_path, [&] {
      return std::make_shared<const std::vector<signed char>>(make());
    });
  }

 private:
  MadeOnce<std::shared_ptr<const std::vector<signed char>>> maps_;
};

// The reference previews written in this run: every fit of a material writes the same preview of
// each reference (the reference's image, the study's display exposure), so the first one does.
class WrittenOnce {
 public:
  // True for the first caller with `path` in this run.
  bool First(const std::string& path) {
    std::lock_guard lock(mutex_);
    return paths_.insert(path).second;
  }

 private:
  std::mutex mutex_;
  std::set<std::string> paths_;
};

struct RunContext {
  const StudySpec& spec;
  const RunOptions& options;
  StudyPaths paths;
  Log* log = nullptr;
  // Shared by the workers; may be null (metrics are the same without it).
  metrics::ReferenceCache* reference_cache = nullptr;
  // Shared by the workers; null: every fit writes its reference previews.
  WrittenOnce* reference_previews = nullptr;
  // Shared by the workers; never null (the runner owns it).
  BrdfSpaceFits* brdf_fits = nullptr;
  // Shared by the workers; null: every job reads its own references.
  LoadedReferences* references = nullptr;
  // Shared by the workers; null: every evaluation finds its reference's pixel regions.
  ReferenceRegions* reference_regions = nullptr;

  // The reference at `image_path`, read once per run where `references` is set.
  std::shared_ptr<const reference_images::Reference> Reference(const std::string& image_path) const {
    if (references) return references->Get(image_path);
    return std::make_shared<const reference_images::Reference>(
        reference_images::LoadReference(image_path));
  }

  // The references at `image_paths`, in their order: read side by side by the workers that ask
  // for them at once where `references` is set (LoadedReferences::GetAll).
  std::vector<std::shared_ptr<const reference_images::Reference>> References(
      const std::vector<std::string>& image_paths) const {
    if (references) return references->GetAll(image_paths);
    std::vector<std::shared_ptr<const reference_images::Reference>> out;
    for (const std::string& path : image_paths) out.push_back(Reference(path));
    return out;
  }
};

}  // namespace shadefit::studies::internal
