// The references a run has read, shared by its workers: a study fits every model of a material to
// the same references (five models x 96 lights on a photometric-stereo set), and reading one
// (decoding the EXR, its scene, mask and shadow-edge mask) costs more than the fit's use of it.
#pragma once

#include <cstddef>
#include <functional>
#include <future>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "shadefit/reference_images/reference.h"

namespace shadefit::studies::internal {

// Each reference read once per run (LoadReference of its image path) by the first worker that
// asks; the others wait for it and share it. A read that threw is forgotten (the next asker
// reports its own error). The least recently asked-for references go when the held bytes pass
// the budget (one that goes lives on in the jobs holding it).
class LoadedReferences {
 public:
  using Shared = std::shared_ptr<const reference_images::Reference>;
  // How a reference is read: reference_images::LoadReference, or a test's stand-in.
  using Loader = std::function<reference_images::Reference(const std::string& image_path)>;

  explicit LoadedReferences(std::size_t byte_budget, Loader load = DefaultLoader());

  Shared Get(const std::string& image_path);

  // Every path's reference, in the paths' order. Workers that ask for the same set at once (the
  // models of one material start together) read different references side by side: each first
  // reads those nobody is reading yet, then waits for the rest. A failed read is reported as
  // Get would report it: the error of the first path, in the paths' order, that fails.
  std::vector<Shared> GetAll(const std::vector<std::string>& image_paths);

 private:
  struct Entry {
    std::shared_future<Shared> value;
    std::size_t bytes = 0;  // 0 until read.
    std::list<std::string>::iterator order;
  };
  static Loader DefaultLoader();
  // Enters `image_path` as read by this thread (its value: `made`'s future), most recent first.
  void ClaimLocked(const std::string& image_path, std::promise<Shared>& made);
  // Reads the reference this thread has claimed (its entry holds `made`'s future), or forgets
  // the claim and rethrows.
  Shared Read(const std::string& image_path, std::promise<Shared>& made);
  void EvictLocked();

  const std::size_t budget_;
  const Loader load_;
  std::mutex mutex_;
  std::map<std::string, Entry> entries_;
  std::list<std::string> order_;  // Most recently asked-for first.
  std::size_t bytes_ = 0;
};

}  // namespace shadefit::studies::internal
