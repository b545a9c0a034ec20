#include "loaded_references.h"

#include <exception>
#include <utility>

namespace shadefit::studies::internal {
namespace {

std::size_t BytesOf(const Image& im) { return im.data.size() * sizeof(float); }

std::size_t BytesOf(const reference_images::Reference& r) {
  return BytesOf(r.image) + BytesOf(r.mask) + BytesOf(r.extrapolated_share) +
         BytesOf(r.shadow_edge) + BytesOf(r.interreflection);
}

}  // namespace

LoadedReferences::Loader LoadedReferences::DefaultLoader() {
  return [](const std::string& image_path) { return reference_images::LoadReference(image_path); };
}

LoadedReferences::LoadedReferences(std::size_t byte_budget, Loader load)
    : budget_(byte_budget), load_(std::move(load)) {}

LoadedReferences::Shared LoadedReferences::Get(const std::string& image_path) {
  std::promise<Shared> made;
  std::shared_future<Shared> found;
  {
    std::lock_guard lock(mutex_);
    if (auto it = entries_.find(image_path); it != entries_.end()) {
      order_.splice(order_.begin(), order_, it->second.order);
      found = it->second.value;
    } else {
      ClaimLocked(image_path, made);
    }
  }
  if (found.valid()) return found.get();
  return Read(image_path, made);
}

std::vector<LoadedReferences::Shared> LoadedReferences::GetAll(
    const std::vector<std::string>& image_paths) {
  std::vector<Shared> got(image_paths.size());
  // First the references nobody has asked for: this thread reads them. One read or being read
  // is left to the second pass, as is everything after a failed read (the second pass reports
  // the first failure in the paths' order, as a path-by-path Get would).
  for (std::size_t i = 0; i < image_paths.size(); ++i) {
    std::promise<Shared> made;
    {
      std::lock_guard lock(mutex_);
      if (entries_.contains(image_paths[i])) continue;
      ClaimLocked(image_paths[i], made);
    }
    try {
      got[i] = Read(image_paths[i], made);
    } catch (...) {
      break;
    }
  }
  for (std::size_t i = 0; i < image_paths.size(); ++i) {
    if (!got[i]) got[i] = Get(image_paths[i]);
  }
  return got;
}

void LoadedReferences::ClaimLocked(const std::string& image_path, std::promise<Shared>& made) {
  order_.push_front(image_path);
  entries_[image_path] = Entry{made.get_future().share(), 0, order_.begin()};
}

LoadedReferences::Shared LoadedReferences::Read(const std::string& image_path,
                                                std::promise<Shared>& made) {
  try {
    Shared value = std::make_shared<const reference_images::Reference>(load_(image_path));
    made.set_value(value);
    std::lock_guard lock(mutex_);
    if (auto it = entries_.find(image_path); it != entries_.end() && it->second.bytes == 0) {
      it->second.bytes = BytesOf(*value);
      bytes_ += it->second.bytes;
      EvictLocked();
    }
    return value;
  } catch (...) {
    made.set_exception(std::current_exception());
    std::lock_guard lock(mutex_);
    if (auto it = entries_.find(image_path); it != entries_.end()) {
      order_.erase(it->second.order);
      entries_.erase(it);
    }
    throw;
  }
}

void LoadedReferences::EvictLocked() {
  // The newest entry stays even over budget: the job that asked for it holds it anyway.
  while (bytes_ > budget_ && order_.size() > 1) {
    auto it = entries_.find(order_.back());
    if (it->second.bytes == 0) break;  // Still being read by its first asker.
    bytes_ -= it->second.bytes;
    entries_.erase(it);
    order_.pop_back();
  }
}

}  // namespace shadefit::studies::internal
