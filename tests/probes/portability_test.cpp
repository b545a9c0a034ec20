// Portability probe: a Lambert material fitted (closed-form least squares) to a GGX key-light
// render ports badly to camera, side and rim lighting; exposure errors give the analytic RMSE.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "probe_test_util.h"
#include "shadefit/render/error.h"

namespace shadefit::testing {
namespace {

probes::ProbeInputs GgxReferences() {
  probes::ProbeInputs in;
  in.renderer = &SharedRenderer();
  in.truth = MakeModel("ggx", "ggx", {"kd=0.5,0.3,0.2", "f0=0.04", "roughness=0.35"});
  for (const char* l : {"key", "camera", "side", "rim"}) {
    in.references.push_back(MakeReference(*in.truth, l));
  }
  return in;
}

// Least-squares kd per channel on one reference: kd = sum(y s) / sum(s^2), s = Lambert render
// with kd = 1 (the one-parameter "fit" of an ad-hoc model to one lighting).
std::vector<double> FitLambert(const probes::ProbeReference& ref) {
  const Image s = SharedRenderer().Render(ref.scene, ModelId::kLambert, {1, 1, 1});
  std::vector<double> kd(3);
  for (int c = 0; c < 3; ++c) {
    double ys = 0, ss = 0;
    for (std::size_t i = 0; i < s.PixelCount(); ++i) {
      if (s.data[i * 4 + 3] < 0.999f) continue;
      ys += ref.image.data[i * 4 + c] * s.data[i * 4 + c];
      ss += s.data[i * 4 + c] * s.data[i * 4 + c];
    }
    kd[c] = ys / ss;
  }
  return kd;
}

TEST(PortabilityProbe, LambertFittedToKeyFailsUnderOtherLightings) {
  probes::ProbeInputs in = GgxReferences();
  probes::ModelUnderTest lambert;
  lambert.label = "lambert-key";
  lambert.model = "lambert";
  lambert.params = FitLambert(in.references[0]);
  lambert.trained_on = {"ggx-key"};
  in.models.push_back(lambert);
  probes::ModelUnderTest exact = *in.truth;
  exact.label = "ggx-key";
  exact.trained_on = {"ggx-key"};
  in.models.push_back(exact);
  const auto r = probes::PortabilityProbe(in);
  const auto& n = r.numbers["lambert-key"];
  std::printf("[ portability ] lambert fitted on key: train %.4f test %.4f ratio %.2f; rim %.4f\n",
              n["train_rmse"].get<double>(), n["test_rmse"].get<double>(),
              n["test_over_train"].get<double>(), n["rmse"]["ggx-rim"].get<double>());
  EXPECT_GT(n["test_over_train"].get<double>(), 2.0);  // measured 3.61
  EXPECT_LT(r.numbers["truth"]["test_rmse"].get<double>(), 1e-4);
  EXPECT_LT(r.numbers["ggx-key"]["test_rmse"].get<double>(), 1e-4);
}

// With the truth's parameters and exposure 2, the error image is the reference itself: RMSE =
// sqrt(mean(ref^2)) over covered pixels.
TEST(PortabilityProbe, ExposureErrorGivesAnalyticRmse) {
  probes::ProbeInputs in = GgxReferences();
  probes::ModelUnderTest m = *in.truth;
  m.label = "double";
  m.exposure = 2.0;
  m.trained_on = {"ggx-key", "ggx-camera"};
  in.models.push_back(m);
  const auto r = probes::PortabilityProbe(in);
  for (const auto& ref : in.references) {
    double sq = 0;
    long n = 0;
    for (std::size_t i = 0; i < ref.image.PixelCount(); ++i) {
      if (ref.image.data[i * 4 + 3] < 0.999f) continue;
      for (int c = 0; c < 3; ++c)
        sq += double(ref.image.data[i * 4 + c]) * ref.image.data[i * 4 + c];
      ++n;
    }
    const double expected = std::sqrt(sq / (3.0 * n));
    EXPECT_NEAR(r.numbers["double"]["rmse"][ref.name].get<double>(), expected, 1e-5 * expected)
        << ref.name;
  }
}

TEST(PortabilityProbe, UnknownTrainingReferenceIsAnError) {
  probes::ProbeInputs in = GgxReferences();
  probes::ModelUnderTest m = *in.truth;
  m.label = "fit";
  m.trained_on = {"gold-key"};
  in.models.push_back(m);
  try {
    probes::PortabilityProbe(in);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "fit: trained_on: 'gold-key' is not one of the references given");
  }
}

}  // namespace
}  // namespace shadefit::testing
