// Where a fit's error lies (studies/runner/src/region_errors.h): a hand-made 4 x 5 frame whose
// regions and means are worked out below by hand, not by the code under test.
#include "region_errors.h"

#include <gtest/gtest.h>

#include "run_context.h"

namespace shadefit::studies::internal {
namespace {

// A frame of 20 covered pixels, all hit, n = +z. The view is +z (n.v = 1) except in column 0,
// where it is tilted to n.v = 0.2 (the rim). The reference is grey 1 everywhere but pixel (3, 4),
// which is 10 (the brightest 5% of 20 lit pixels: one pixel, the highlight).
struct Frame {
  Image ref{4, 5, 3, 1.0f}, fit{4, 5, 3, 1.0f}, measured{4, 5, 1, 1.0f};
  GBuffer gb;
  Frame() {
    gb.width = 4;
    gb.height = 5;
    gb.position = Image(4, 5, 4, 1.0f);
    gb.normal = Image(4, 5, 4, 0.0f);
    gb.view = Image(4, 5, 3, 0.0f);
    for (int y = 0; y < 5; ++y) {
      for (int x = 0; x < 4; ++x) {
        gb.normal.at(x, y, 2) = 1.0f;
        gb.normal.at(x, y, 3) = 1.0f;
        gb.view.at(x, y, 2) = x == 0 ? 0.2f : 1.0f;
        gb.view.at(x, y, 0) = x == 0 ? 0.9797959f : 0.0f;
      }
    }
    for (int c = 0; c < 3; ++c) ref.at(3, 4, c) = 10.0f;
  }
};

TEST(RegionErrors, SplitsHighlightRimAndBody) {
  Frame f;
  // The fit: the highlight 8 (2 too dark), the rim 1.5 in red only (+0.5 red: luminance
  // +0.2126 * 0.5 = +0.1063), the body exact but for one pixel 0.5 (-0.5).
  for (int c = 0; c < 3; ++c) f.fit.at(3, 4, c) = 8.0f;
  for (int y = 0; y < 5; ++y) f.fit.at(0, y, 0) = 1.5f;
  for (int c = 0; c < 3; ++c) f.fit.at(2, 2, c) = 0.5f;
  const nlohmann::json r = RegionErrors(f.ref, f.fit, f.measured, f.gb);
  EXPECT_EQ(r["highlight"]["pixels"], 1);
  EXPECT_NEAR(r["highlight"]["signed"].get<double>(), -2.0, 1e-6);
  EXPECT_NEAR(r["highlight"]["ref"].get<double>(), 10.0, 1e-6);
  EXPECT_EQ(r["rim"]["pixels"], 5);
  EXPECT_NEAR(r["rim"]["signed"].get<double>(), 0.1063, 1e-6);
  EXPECT_NEAR(r["rim"]["abs"].get<double>(), 0.1063, 1e-6);
  EXPECT_EQ(r["body"]["pixels"], 14);
  EXPECT_NEAR(r["body"]["signed"].get<double>(), -0.5 / 14, 1e-6);
  EXPECT_NEAR(r["body"]["abs"].get<double>(), 0.5 / 14, 1e-6);
  EXPECT_NEAR(r["body"]["ref"].get<double>(), 1.0, 1e-6);
}

TEST(RegionErrors, OnlyMeasuredPixelsCount) {
  Frame f;
  for (int y = 0; y < 5; ++y) f.measured.at(0, y, 0) = 0.0f;  // The rim is extrapolated.
  f.measured.at(3, 4, 0) = 0.0f;                             // So is the bright pixel.
  const nlohmann::json r = RegionErrors(f.ref, f.fit, f.measured, f.gb);
  EXPECT_EQ(r["rim"]["pixels"], 0);
  EXPECT_TRUE(r["rim"]["signed"].is_null());
  // 14 measured pixels, all grey 1: the brightest 5% is the one at the top of the sort.
  EXPECT_EQ(r["highlight"]["pixels"].get<int>() + r["body"]["pixels"].get<int>(), 14);
}

// A study finds a reference's regions once (ReferenceRegions, by image path) and sums each fit
// over them: one map of the frame above serves a fit that is exact and one that is not, each with
// its own numbers; a second path gets a map of its own, a path seen before the first one's.
TEST(RegionErrors, OneReferenceMapServesEveryFit) {
  Frame f;
  ReferenceRegions store;
  int made = 0;
  const auto make = [&] {
    ++made;
    return PixelRegions(f.ref, f.measured, f.gb);
  };
  const auto regions = store.Get("/refs/grey-key.exr", make);
  const nlohmann::json exact = RegionErrors(f.ref, f.ref, *store.Get("/refs/grey-key.exr", make));
  for (int c = 0; c < 3; ++c) f.fit.at(3, 4, c) = 8.0f;  // The highlight 2 too dark.
  const nlohmann::json darker = RegionErrors(f.ref, f.fit, *store.Get("/refs/grey-key.exr", make));
  EXPECT_EQ(made, 1);
  EXPECT_EQ(exact["highlight"]["pixels"], 1);
  EXPECT_EQ(exact["rim"]["pixels"], 5);
  EXPECT_EQ(exact["body"]["pixels"], 14);
  EXPECT_NEAR(exact["highlight"]["signed"].get<double>(), 0.0, 1e-12);
  EXPECT_NEAR(darker["highlight"]["signed"].get<double>(), -2.0, 1e-6);
  EXPECT_NEAR(darker["body"]["abs"].get<double>(), 0.0, 1e-12);
  const auto other = store.Get("/refs/grey-rim.exr", [&] {
    ++made;
    return std::vector<signed char>(20, 2);
  });
  EXPECT_EQ(made, 2);
  EXPECT_NE(other.get(), regions.get());
  EXPECT_EQ(store.Get("/refs/grey-key.exr", make).get(), regions.get());
}

}  // namespace
}  // namespace shadefit::studies::internal
