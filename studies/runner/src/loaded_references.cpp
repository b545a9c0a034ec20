#include "loaded_references.h"

#include <exception>

namespace shadefit::studies::internal {
namespace {

std::size_t BytesOf(const Image& im) { return im.data.size() * sizeof(float); }

std::size_t BytesOf(const reference_images::Reference& r) {
  return BytesOf(r.image) + BytesOf(r.mask) + BytesOf(r.extrapolated_share) +
         BytesOf(r.shadow_edge) + BytesOf(r.interreflection);
}

}  // namespace

LoadedReferences::Shared LoadedReferences::Get(const std::string& image_path) {
  std::promise<Shared> made;
  std::shared_future<Shared> found;
  {
    std::lock_guard lock(mutex_);
    if (auto it = entries_.find(image_path); it != entries_.end()) {
      order_.splice(order_.begin(), order_, it->second.order);
      found = it->second.value;
    } else {
      order_.push_front(image_path);
      entries_[image_path] = Entry{made.get_future().share(), 0, order_.begin()};
    }
  }
  if (found.valid()) return found.get();
  try {
    Shared value =
        std::make_shared<const reference_images::Reference>(reference_images::LoadReference(image_path));
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
