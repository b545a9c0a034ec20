#include "brdf_space_fits.h"

#include "shadefit/reference_images/measured_brdf.h"

namespace shadefit::studies::internal {

std::shared_ptr<const fit::BrdfSpaceData> BrdfSpaceFits::Samples(const std::string& brdf_path) {
  std::promise<std::shared_ptr<const fit::BrdfSpaceData>> made;
  std::shared_future<std::shared_ptr<const fit::BrdfSpaceData>> found;
  {
    std::lock_guard lock(mutex_);
    const auto it = samples_.find(brdf_path);
    if (it != samples_.end()) {
      found = it->second;
    } else {
      samples_[brdf_path] = made.get_future().share();
      sample_order_.push_back(brdf_path);
      if (sample_order_.size() > kKeptSamples) {  // Jobs holding it keep their shared_ptr.
        samples_.erase(sample_order_.front());
        sample_order_.pop_front();
      }
    }
  }
  if (found.valid()) return found.get();
  try {
    const std::unique_ptr<reference_images::MeasuredBrdf> brdf =
        reference_images::LoadMeasuredBrdf(brdf_path);
    auto data = std::make_shared<const fit::BrdfSpaceData>(
        fit::SampleBrdfSpace(*brdf, fit::BrdfSpaceSampling{}));
    made.set_value(data);
    return data;
  } catch (...) {
    made.set_exception(std::current_exception());
    std::lock_guard lock(mutex_);
    samples_.erase(brdf_path);  // The next job tries again and reports its own error.
    throw;
  }
}

fit::FitResult BrdfSpaceFits::Get(const std::string& brdf_path, const ModelInfo& model,
                                  const std::vector<FixedValue>& fixed,
                                  const fit::FitOptions& options, const std::string& key) {
  const std::string id = brdf_path + "\n" + model.name + "\n" + key;
  std::promise<fit::FitResult> made;
  std::shared_future<fit::FitResult> found;
  {
    std::lock_guard lock(mutex_);
    const auto it = fits_.find(id);
    if (it != fits_.end()) {
      found = it->second;
    } else {
      fits_[id] = made.get_future().share();
    }
  }
  if (found.valid()) return found.get();
  try {
    fit::FitResult r = fit::FitBrdfSpace(model, fixed, *Samples(brdf_path), options);
    made.set_value(r);
    return r;
  } catch (...) {
    made.set_exception(std::current_exception());
    std::lock_guard lock(mutex_);
    fits_.erase(id);
    throw;
  }
}

}  // namespace shadefit::studies::internal
