#include "brdf_space_fits.h"

#include "shadefit/reference_images/measured_brdf.h"

namespace shadefit::studies::internal {

fit::FitResult BrdfSpaceFits::Get(const std::string& brdf_path, const ModelInfo& model,
                                  const std::vector<FixedValue>& fixed,
                                  const fit::FitOptions& options, const std::string& key,
                                  double* solved_here) {
  *solved_here = 0.0;
  return fits_.Get(brdf_path + "\n" + model.name + "\n" + key, [&] {
    const std::shared_ptr<const fit::BrdfSpaceData> samples = samples_.Get(brdf_path, [&] {
      const std::unique_ptr<reference_images::MeasuredBrdf> brdf =
          reference_images::LoadMeasuredBrdf(brdf_path);
      return std::make_shared<const fit::BrdfSpaceData>(
          fit::SampleBrdfSpace(*brdf, fit::BrdfSpaceSampling{}));
    });
    fit::FitResult fit = fit::FitBrdfSpace(model, fixed, *samples, options);
    *solved_here = fit.seconds;
    return fit;
  });
}

}  // namespace shadefit::studies::internal
