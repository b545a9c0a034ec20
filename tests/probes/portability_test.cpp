// Portability probe: a Lambert material fitted (closed-form least squares) to a GGX key-light
// render ports badly to camera, side and rim lighting; every RMSE the probe reports is recomputed
// here from renders (per reference, and pooled over the train and test sets); a perturbed truth
// is told apart from the truth; exposure errors give the analytic RMSE.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "probe_test_util.h"
#include "shadefit/base/error.h"

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

// Squared error sum and pixel count of a model's render against a reference, over pixels covered
// (>= 0.999) in both, RGB: the probe's definition (docs/probes.md, "Portability").
struct SquaredError {
  double sum = 0;
  long pixels = 0;
  double Rmse() const { return std::sqrt(sum / (3.0 * pixels)); }
};
SquaredError ErrorOf(const probes::ModelUnderTest& m, const probes::ProbeReference& ref) {
  const Image img = SharedRenderer().Render(ref.scene, m.model->id, m.params);
  SquaredError e;
  for (std::size_t i = 0; i < img.PixelCount(); ++i) {
    if (img.data[i * 4 + 3] < 0.999f || ref.image.data[i * 4 + 3] < 0.999f) continue;
    for (int c = 0; c < 3; ++c) {
      const double d = m.exposure * img.data[i * 4 + c] - ref.image.data[i * 4 + c];
      e.sum += d * d;
    }
    ++e.pixels;
  }
  return e;
}

// Every number of one model recomputed: rmse per reference, pooled train and test, their ratio.
void ExpectNumbersRecomputed(const probes::ProbeResult& r, const probes::ProbeInputs& in,
                             const probes::ModelUnderTest& m) {
  SquaredError train, test;
  for (const auto& ref : in.references) {
    const SquaredError e = ErrorOf(m, ref);
    EXPECT_NEAR(r.numbers[m.label]["rmse"][ref.name].get<double>(), e.Rmse(), 1e-6 * e.Rmse())
        << m.label << " " << ref.name;
    const bool trained =
        std::find(m.trained_on.begin(), m.trained_on.end(), ref.name) != m.trained_on.end();
    SquaredError& pool = trained ? train : test;
    pool.sum += e.sum;
    pool.pixels += e.pixels;
  }
  ASSERT_GT(train.pixels, 0);
  ASSERT_GT(test.pixels, 0);
  EXPECT_NEAR(r.numbers[m.label]["train_rmse"].get<double>(), train.Rmse(), 1e-6 * train.Rmse());
  EXPECT_NEAR(r.numbers[m.label]["test_rmse"].get<double>(), test.Rmse(), 1e-6 * test.Rmse());
  EXPECT_NEAR(r.numbers[m.label]["test_over_train"].get<double>(), test.Rmse() / train.Rmse(),
              1e-5 * test.Rmse() / train.Rmse());
}

TEST(PortabilityProbe, LambertFittedToKeyFailsUnderOtherLightings) {
  probes::ProbeInputs in = GgxReferences();
  probes::ModelUnderTest lambert;
  lambert.label = "lambert-key";
  lambert.model = FindModel("lambert");
  lambert.params = FitLambert(in.references[0]);
  lambert.trained_on = {"ggx-key"};
  in.models.push_back(lambert);
  // A perturbed truth (roughness 0.35 -> 0.45): close, but it must be told apart from the truth.
  probes::ModelUnderTest rougher = MakeModel("ggx-rougher", "ggx",
                                             {"kd=0.5,0.3,0.2", "f0=0.04", "roughness=0.45"});
  rougher.trained_on = {"ggx-key"};
  in.models.push_back(rougher);
  const auto r = probes::PortabilityProbe(in);
  const auto& n = r.numbers["lambert-key"];
  std::printf(
      "[ portability ] lambert fitted on key: train %.4f test %.4f ratio %.2f; rim %.4f; "
      "rougher ggx test %.5f; truth %.2g\n",
      n["train_rmse"].get<double>(), n["test_rmse"].get<double>(),
      n["test_over_train"].get<double>(), n["rmse"]["ggx-rim"].get<double>(),
      r.numbers["ggx-rougher"]["test_rmse"].get<double>(),
      r.numbers["truth"]["test_rmse"].get<double>());
  ExpectNumbersRecomputed(r, in, lambert);
  ExpectNumbersRecomputed(r, in, rougher);
  EXPECT_GT(n["test_over_train"].get<double>(), 2.0);  // measured 3.61
  const double floor = r.numbers["truth"]["test_rmse"].get<double>();
  EXPECT_LT(floor, 1e-4);
  EXPECT_GT(r.numbers["ggx-rougher"]["test_rmse"].get<double>(), std::max(1e-3, 10 * floor));
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
